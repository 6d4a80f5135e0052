// shapesense-train: trains, evaluates and checks the WaldBoost/LBP bowl detector.
//
//   shapesense-train generate --out DIR [--seed S] [--positive-scenes N] [--negative-scenes M]
//                             [--wide-scenes W [--wide-first I] [--wide-split train]]
//   shapesense-train train --data DIR --out MODELS [--seed S] [--stages T] [--views a,b,c]
//   shapesense-train eval --models MODELS --data DIR      (AP50, miss rate at 0.1 FPPI)
//   shapesense-train diagnose --models MODELS --data DIR  (why each missed bowl is missed)
//   shapesense-train real --models MODELS --tum DIR       (detections on a TUM recording)
//   shapesense-train export-wbdetector --data DIR --out DIR   (image folders for the OpenCV
//                                                              WBDetector peer, bench/bowls_bench)
//
// Training (train.h) is deterministic for a given dataset and seed, and resumable.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset.h"
#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/core/bowls/bowl_model.h"
#include "shapesense/core/bowls/depth_preprocess.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/tum_recording.h"
#include "train.h"
#include "wbdetector_export.h"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace shapesense;
using namespace shapesense::train;

namespace {

double elapsed(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The 3D check after the classifier (keepBowlShaped), on the Hough planes of each frame.
struct BowlVerification {
  bool on = true;
  BowlGeometryParams params;
  /// Default: the models' operating point.
  std::optional<double> min_unverified_score;
};

std::vector<BowlTruthBox> truthOf(const DatasetFrame& f) {
  std::vector<BowlTruthBox> t;
  for (const auto& b : f.bowls)
    if (b.upright) t.push_back({b.box, b.difficult});
  return t;
}

/// Counts, by reason, the classifier's detections of required bowls (IoU >= 0.5 with a
/// non-difficult upright bowl) that the 3D check rejects; with --verbose each is printed.
void countRejectedBowls(const std::vector<BowlDetection>& candidates, const DatasetFrame& f,
                        const cv::Mat& depth, const PlaneDetection& planes,
                        const BowlGeometryParams& params, std::map<std::string, int>& counts) {
  for (const auto& d : candidates) {
    const bool on_bowl = std::any_of(f.bowls.begin(), f.bowls.end(), [&](const auto& b) {
      return b.upright && !b.difficult && boxIoU(d.box, b.box) >= 0.5;
    });
    if (!on_bowl) continue;
    const auto measured = measureBowlGeometry(depth, f.intrinsics, d.box, planes, params);
    if (const auto& reason = measured.rejection) {
      const auto& g = measured.geometry;
      ++counts[toString(*reason)];
      spdlog::debug(
          "{} [{} {} {} {}] {} score {:.1f}: {} (rim {:.3f} height {:.3f} widening {:.2f} dish "
          "{:.2f})",
          f.file, d.box.x, d.box.y, d.box.width, d.box.height, d.view, d.score, toString(*reason),
          g.rim_diameter_m, g.height_m, g.rim_to_foot_width, g.dish_depth);
    }
  }
}

int runEval(const fs::path& models, const fs::path& data, const BowlDetectorParams& p,
            const BowlVerification& verification, bool verbose, const fs::path& raw_out) {
  const auto detector = BowlDetector::load(models, p);
  HoughPlaneDetector plane_detector;
  std::ofstream raw_file;
  if (!raw_out.empty()) raw_file.open(raw_out);
  requireEvaluationTruth(data);
  const auto frames = readDataset(data);
  std::vector<BowlEvalFrame> eval;
  std::map<std::string, std::pair<int, int>> per_view;  // found, total
  std::map<std::string, int> rejected_bowls;            // by the 3D check's reason
  double secs = 0;
  for (const auto& f : frames) {
    const cv::Mat depth = readDepth(data, f);
    const auto t = std::chrono::steady_clock::now();
    BowlEvalFrame e;
    e.detections = detector.detect(depth, f.intrinsics);
    secs += elapsed(t);
    if (verification.on) {
      const auto planes = plane_detector.detect(depth, f.intrinsics);
      const auto t_verify = std::chrono::steady_clock::now();
      auto candidates = e.detections;
      e.detections =
          keepBowlShaped(std::move(e.detections), depth, f.intrinsics, planes, verification.params,
                         verification.min_unverified_score.value_or(
                             detector.operatingPoint().unverified_score_threshold));
      secs += elapsed(t_verify);
      countRejectedBowls(candidates, f, depth, planes, verification.params, rejected_bowls);
    }
    if (raw_file.is_open()) {  // accepted windows before NMS and the truth, for offline NMS studies
      json line = {{"file", f.file}, {"truth", json::array()}, {"raw", json::array()}};
      for (const auto& b : f.bowls)
        if (b.upright)
          line["truth"].push_back(
              {b.box.x, b.box.y, b.box.width, b.box.height, b.difficult, b.view});
      for (const auto& d : detector.detectRaw(depth, f.intrinsics))
        line["raw"].push_back({d.box.x, d.box.y, d.box.width, d.box.height, d.score, d.view});
      raw_file << line.dump() << "\n";
    }
    e.truth = truthOf(f);
    for (const auto& b : f.bowls) {
      if (!b.upright || b.difficult) continue;
      auto& pv = per_view[b.view];
      ++pv.second;
      for (const auto& d : e.detections)
        if (boxIoU(d.box, b.box) >= 0.5) {
          ++pv.first;
          break;
        }
    }
    if (verbose) {
      std::printf("%s:", f.file.c_str());
      for (const auto& d : e.detections)
        std::printf(" [%d %d %d %d %.2f %s]", d.box.x, d.box.y, d.box.width, d.box.height, d.score,
                    d.view.c_str());
      std::printf("\n");
    }
    eval.push_back(std::move(e));
  }
  for (const auto& [reason, count] : rejected_bowls)
    std::printf("true bowls the 3D check rejects: %d, %s\n", count, reason.c_str());
  const auto r = evaluateBowlDetections(eval, 0.5, 0.1);
  std::printf(
      "frames %d  bowls %d  AP50 %.4f  miss rate @0.1 FPPI %.4f  max recall %.4f  TP %d FP %d  "
      "mean %.2f ms/frame\n",
      r.frames, r.positives, r.ap, r.miss_rate_at_fppi, r.max_recall, r.true_positives,
      r.false_positives, 1000.0 * secs / std::max<std::size_t>(1, frames.size()));
  for (const auto& [v, c] : per_view)
    std::printf("  view %-6s recall@IoU0.5 %d/%d\n", v.c_str(), c.first, c.second);
  return 0;
}

// Why each non-difficult upright bowl is missed (the first cause that applies):
//  found        a final detection has IoU >= 0.5;
//  nms          an accepted window (before NMS) has IoU >= 0.5 but NMS kept another box;
//  calibration  accepted windows lie on the bowl (IoU >= 0.25) but none reaches IoU 0.5;
//  classifier   no accepted window on the bowl at the score threshold; the best final score
//               of any window with IoU >= 0.5 that passes the stages' own thresholds
//               (threshold -inf) is printed, "none" when every such window is rejected early.
int runDiagnose(const fs::path& models, const fs::path& data, const BowlDetectorParams& p) {
  const auto detector = BowlDetector::load(models, p);
  BowlDetectorParams all = p;
  all.score_threshold = -1e6;
  const auto loose = BowlDetector::load(models, all);
  requireEvaluationTruth(data);
  const auto frames = readDataset(data);
  std::map<std::string, std::map<std::string, int>> causes;  // view -> cause -> count
  auto best = [](const std::vector<BowlDetection>& ds, const cv::Rect& box) {
    const BowlDetection* b = nullptr;
    double iou = 0;
    for (const auto& d : ds)
      if (double v = boxIoU(d.box, box); v > iou) iou = v, b = &d;
    return std::pair{iou, b};
  };
  for (const auto& f : frames) {
    const cv::Mat depth = readDepth(data, f);
    const auto raw = detector.detectRaw(depth, f.intrinsics);
    const auto kept =
        suppressNonMaxima(raw, p.nms_max_overlap, p.box_merge_iou, p.support_score_weight);
    std::vector<BowlDetection> low;
    bool low_done = false;
    for (const auto& b : f.bowls) {
      if (!b.upright || b.difficult) continue;
      std::string cause;
      const auto [fi, fd] = best(kept, b.box);
      const auto [ri, rd] = best(raw, b.box);
      if (fi >= 0.5)
        cause = "found";
      else if (ri >= 0.5)
        cause = "nms";
      else if (ri >= 0.25)
        cause = "calibration";
      else
        cause = "classifier";
      ++causes[b.view][cause];
      if (cause == "found") continue;
      std::printf("%s %-6s truth [%d %d %d %d] %-11s", f.file.c_str(), b.view.c_str(), b.box.x,
                  b.box.y, b.box.width, b.box.height, cause.c_str());
      if (fd)
        std::printf(" final best IoU %.2f [%d %d %d %d %.1f %s]", fi, fd->box.x, fd->box.y,
                    fd->box.width, fd->box.height, fd->score, fd->view.c_str());
      if (rd)
        std::printf(" raw best IoU %.2f [%d %d %d %d %.1f %s]", ri, rd->box.x, rd->box.y,
                    rd->box.width, rd->box.height, rd->score, rd->view.c_str());
      if (cause == "classifier") {
        if (!low_done) low = loose.detectRaw(depth, f.intrinsics), low_done = true;
        std::map<std::string, double> top;  // view -> best score among windows with IoU >= 0.5
        for (const auto& d : low)
          if (boxIoU(d.box, b.box) >= 0.5)
            top[d.view] = top.contains(d.view) ? std::max(top[d.view], d.score) : d.score;
        std::printf(" best score at IoU>=0.5:");
        if (top.empty()) std::printf(" none");
        for (const auto& [v, s] : top) std::printf(" %s %.1f", v.c_str(), s);
      }
      std::printf("\n");
    }
  }
  for (const auto& [v, c] : causes) {
    std::printf("view %-6s", v.c_str());
    for (const auto& [k, n] : c) std::printf("  %s %d", k.c_str(), n);
    std::printf("\n");
  }
  return 0;
}

// Detections on real recordings (a check only: real frames are never used for training or
// for choosing). Each candidate the classifier keeps after NMS is printed with its 3D
// geometry, or with the reason the 3D check rejects it; the counts are of verified bowls.
int runReal(const fs::path& models, const std::vector<fs::path>& recordings,
            const BowlDetectorParams& p, const BowlVerification& verification) {
  const auto detector = BowlDetector::load(models, p);
  const double min_unverified_score = verification.min_unverified_score.value_or(
      detector.operatingPoint().unverified_score_threshold);
  HoughPlaneDetector plane_detector;
  int total_frames = 0, total_bowls = 0;
  for (const auto& tum : recordings) {
    // The driver's reader: camera.json's intrinsics and depth scale when the recording has one.
    const TumIndex index = readTumIndex(tum);
    for (const auto& problem : index.problems) spdlog::warn("{}", problem);
    int n = 0, bowls = 0;
    for (const auto& entry : index.depth) {
      const fs::path file = tum / entry.relative_path;
      const cv::Mat raw = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
      if (raw.empty() || raw.type() != CV_16UC1) {
        spdlog::error("{}: not a 16-bit depth PNG", file.string());
        return 1;
      }
      cv::Mat mm;
      raw.convertTo(mm, CV_16UC1, 1000.0 / index.camera.depth_scale);
      const auto dets = detector.detect(mm, index.camera.intrinsics);
      const auto planes = plane_detector.detect(mm, index.camera.intrinsics);
      std::printf("%s frame %d (%s):", tum.filename().c_str(), ++n, entry.relative_path.c_str());
      for (const auto& d : dets) {
        std::printf(" [%d %d %d %d score %.2f %s", d.box.x, d.box.y, d.box.x + d.box.width - 1,
                    d.box.y + d.box.height - 1, d.score, d.view.c_str());
        const auto measured =
            measureBowlGeometry(mm, index.camera.intrinsics, d.box, planes, verification.params);
        const BowlGeometry& g = measured.geometry;
        const bool reported = reportsBowl(measured, d.score, min_unverified_score);
        bowls += reported || !verification.on;
        if (measured.isBowl())
          std::printf(" BOWL rim %.1f cm height %.1f cm widening %.2f dish %.2f]",
                      100 * g.rim_diameter_m, 100 * g.height_m, g.rim_to_foot_width, g.dish_depth);
        else
          std::printf(" %s: %s]", reported ? "BOWL, unverified" : "rejected",
                      toString(*measured.rejection).c_str());
      }
      std::printf("\n");
    }
    std::printf("%s: %d bowls reported on %d frames\n", tum.filename().c_str(), bowls, n);
    total_frames += n;
    total_bowls += bowls;
  }
  std::printf("all: %d bowls reported on %d frames\n", total_bowls, total_frames);
  return 0;
}

/// Every subcommand's option values, as CLI11 fills them.
struct CommandLine {
  GenerateParams generate;
  fs::path generate_out;
  TrainOptions train;
  std::string train_views = "top,middle,side";
  // eval, diagnose and real
  fs::path models, data;
  BowlDetectorParams scan;
  bool verbose = false;
  fs::path raw_out;
  std::vector<fs::path> recordings;
  BowlVerification verification;
  // export-wbdetector
  WbDetectorExportParams wbdetector;
  fs::path wbdetector_data, wbdetector_out;
  std::string wbdetector_views = "top,middle,side";
};

struct Subcommands {
  CLI::App* generate;
  CLI::App* train;
  CLI::App* eval;
  CLI::App* diagnose;
  CLI::App* real;
  CLI::App* wbdetector;
};

CLI::App* addGenerateCommand(CLI::App& app, CommandLine& c) {
  GenerateParams& gp = c.generate;
  auto* gen = app.add_subcommand("generate", "render a synthetic bowl dataset");
  gen->add_option("--out", c.generate_out, "dataset folder")->required();
  gen->add_option("--seed", gp.seed, "scene seed base");
  gen->add_option("--positive-scenes", gp.positive_scenes, "scenes with upright bowls");
  gen->add_option("--negative-scenes", gp.negative_scenes, "scenes without upright bowls");
  gen->add_option("--frames-per-scene", gp.frames_per_scene);
  gen->add_option("--blank-room", gp.blank_room_fraction,
                  "fraction of frames whose room reads no depth");
  gen->add_option("--wide-scenes", gp.wide_scenes,
                  "frames from the evaluation's wide scene distribution (rooms, furniture, "
                  "clutter, many camera heights; one per scene), after the table-top scenes")
      ->check(CLI::NonNegativeNumber);
  gen->add_option("--wide-first", gp.wide_first, "index of the first wide scene")
      ->check(CLI::NonNegativeNumber);
  gen->add_option("--wide-split", gp.wide_split,
                  "split of the wide scenes: train (for training), validation or test")
      ->check(CLI::IsMember({"train", "validation", "val", "test"}));
  gen->add_option("--threads", gp.threads);
  return gen;
}

CLI::App* addTrainCommand(CLI::App& app, CommandLine& c) {
  TrainOptions& to = c.train;
  auto* tr = app.add_subcommand("train", "train one WaldBoost classifier per view");
  tr->add_option("--data", to.data, "dataset folder")->required();
  tr->add_option("--out", to.out, "models folder")->required();
  tr->add_option("--seed", to.seed, "bootstrapping seed");
  tr->add_option("--stages", to.stages);
  tr->add_option("--miss-rate", to.miss_rate, "target miss rate of the rejection thresholds");
  tr->add_option("--pool", to.pool, "negative pool size");
  tr->add_option("--refill-every", to.refill_every);
  tr->add_option("--window-width", to.window_width);
  tr->add_option("--jitter", to.jitter,
                 "positives shifted by up to this many pixels (plus shape), each also mirrored");
  tr->add_option("--views", c.train_views);
  tr->add_option("--threads", to.threads);
  return tr;
}

// Scan options of eval and diagnose (defaults: BowlDetectorParams).
void addScanOptions(CLI::App& a, BowlDetectorParams& dp) {
  a.add_option("--threshold", dp.score_threshold,
               "final score threshold (default: the models' operating point)");
  a.add_option("--scale-step", dp.scale_step, "pyramid scale step");
  a.add_option("--stride", dp.stride, "window stride (level pixels)");
  a.add_option("--nms-overlap", dp.nms_max_overlap, "NMS inscribed-circle overlap");
  a.add_option("--merge-iou", dp.box_merge_iou,
               "box = mean of accepted windows with this IoU (0 = off)");
  a.add_option("--support-weight", dp.support_score_weight,
               "score += weight * ln(windows merged into the box) (0 = off)");
  a.add_flag("!--no-depth-gate", dp.depth_gate, "classify every window whatever the depth");
}

// The 3D check's options, of eval and real.
void addVerificationOptions(CLI::App& a, BowlVerification& verification) {
  auto& g = verification.params;
  a.add_flag("!--no-verify", verification.on, "the classifier's detections, without the 3D check");
  a.add_option("--unverified-score", verification.min_unverified_score,
               "3D check: score keeping a detection the depth cannot settle");
  a.add_option("--min-rim-to-foot", g.min_rim_to_foot_width, "3D check: rim over foot width");
  a.add_option("--height-ratio-min", g.min_height_to_diameter, "3D check: height / rim, min");
  a.add_option("--height-ratio-max", g.max_height_to_diameter, "3D check: height / rim, max");
  a.add_option("--band-fraction", g.band_fraction, "3D check: rim / foot band share");
  a.add_option("--box-samples", g.max_box_samples,
               "3D check: samples of the box at most (0 = every pixel)");
}

CLI::App* addEvalCommand(CLI::App& app, CommandLine& c) {
  auto* ev = app.add_subcommand("eval", "AP50 and miss rate at 0.1 FPPI on a dataset");
  ev->add_option("--models", c.models)->required();
  ev->add_option("--data", c.data)->required();
  addScanOptions(*ev, c.scan);
  ev->add_flag("--verbose", c.verbose);
  ev->add_option("--raw-out", c.raw_out,
                 "write every accepted window before NMS and the truth (JSON lines)");
  addVerificationOptions(*ev, c.verification);
  return ev;
}

CLI::App* addDiagnoseCommand(CLI::App& app, CommandLine& c) {
  auto* dg = app.add_subcommand(
      "diagnose", "why each missed bowl is missed (classifier, box calibration or NMS)");
  dg->add_option("--models", c.models)->required();
  dg->add_option("--data", c.data)->required();
  addScanOptions(*dg, c.scan);
  return dg;
}

CLI::App* addRealCommand(CLI::App& app, CommandLine& c) {
  auto* re = app.add_subcommand("real", "print detections on a TUM recording");
  re->add_option("--models", c.models)->required();
  re->add_option("--tum", c.recordings, "TUM recording folders")->required();
  re->add_option("--threshold", c.scan.score_threshold,
                 "final score threshold (default: the models' operating point)");
  addVerificationOptions(*re, c.verification);
  return re;
}

CLI::App* addWbDetectorCommand(CLI::App& app, CommandLine& c) {
  WbDetectorExportParams& wp = c.wbdetector;
  auto* wb = app.add_subcommand("export-wbdetector",
                                "positive crops and bowl-free images for OpenCV's WBDetector");
  wb->add_option("--data", c.wbdetector_data, "dataset folder")->required();
  wb->add_option("--out", c.wbdetector_out, "output folder (one subfolder per view)")->required();
  wb->add_option("--views", c.wbdetector_views);
  wb->add_option("--max-bowls", wp.max_bowls_per_view, "bowls per view used as positives");
  wb->add_option("--target-positives", wp.target_positives,
                 "positives per view (shifted / mirrored variants)");
  return wb;
}

/// "top,middle" -> {"top", "middle"}.
std::vector<std::string> splitViews(const std::string& list) {
  std::vector<std::string> views;
  std::stringstream ss(list);
  for (std::string v; std::getline(ss, v, ',');) views.push_back(v);
  return views;
}

int runCommand(const Subcommands& s, const CommandLine& c) {
  if (s.generate->parsed()) {
    generateDataset(c.generate_out, c.generate);
    return 0;
  }
  if (s.train->parsed()) {
    TrainOptions options = c.train;
    options.views = splitViews(c.train_views);
    return runTrain(options);
  }
  if (c.verbose) spdlog::set_level(spdlog::level::debug);
  if (s.eval->parsed())
    return runEval(c.models, c.data, c.scan, c.verification, c.verbose, c.raw_out);
  if (s.diagnose->parsed()) return runDiagnose(c.models, c.data, c.scan);
  if (s.real->parsed()) return runReal(c.models, c.recordings, c.scan, c.verification);
  if (s.wbdetector->parsed()) {
    WbDetectorExportParams params = c.wbdetector;
    params.views = splitViews(c.wbdetector_views);
    exportWbDetectorData(c.wbdetector_data, c.wbdetector_out, params);
    return 0;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"shapesense-train: WaldBoost/LBP bowl detector training and evaluation"};
  app.require_subcommand(1);
  CommandLine c;
  // A braced list is evaluated left to right: --help lists the subcommands in this order.
  const Subcommands subcommands{addGenerateCommand(app, c), addTrainCommand(app, c),
                                addEvalCommand(app, c),     addDiagnoseCommand(app, c),
                                addRealCommand(app, c),     addWbDetectorCommand(app, c)};
  CLI11_PARSE(app, argc, argv);
  try {
    return runCommand(subcommands, c);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
