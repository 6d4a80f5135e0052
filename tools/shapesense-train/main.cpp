// shapesense-train: trains, evaluates and checks the WaldBoost/LBP bowl detector.
//
//   shapesense-train generate --out DIR [--seed S] [--positive-scenes N] [--negative-scenes M]
//   shapesense-train train --data DIR --out MODELS [--seed S] [--stages T] [--views a,b,c]
//   shapesense-train eval --models MODELS --data DIR      (AP50, miss rate at 0.1 FPPI)
//   shapesense-train diagnose --models MODELS --data DIR  (why each missed bowl is missed)
//   shapesense-train real --models MODELS --tum DIR       (detections on a TUM recording)
//   shapesense-train export-wbdetector --data DIR --out DIR   (image folders for the OpenCV
//                                                              WBDetector peer, bench/bowls_bench)
//
// Training is deterministic for a given dataset and seed, and resumable: the state at every
// negative-pool refill is checkpointed in MODELS/.checkpoints/ and a rerun continues from it.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <numeric>
#include <random>

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
#include "wbdetector_export.h"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace shapesense;
using namespace shapesense::train;

namespace {

struct Prepared {
  cv::Mat img8;
  cv::Mat filled;
  double fx = 525.0;
};

struct TrainOptions {
  fs::path data, out;
  std::uint64_t seed = 1;
  int stages = 100;
  double miss_rate = 0.05;
  std::size_t pool = 4000;
  int refill_every = 4;
  int window_width = 24;
  double margin = 0.125;
  double min_width_m = 0.08, max_width_m = 0.45;
  std::vector<std::string> views = {"top", "middle", "side"};
  int threads = 2;
  int jitter = 1;  // +-px shifts of positives at their pyramid level
};

double elapsed(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
  std::uint64_t x = a * 0x9E3779B97F4A7C15ULL ^ (b + 0x632BE59BD9B4E019ULL + (a << 6) + (a >> 2));
  x ^= x >> 31;
  x *= 0xBF58476D1CE4E5B9ULL;
  return x ^ (x >> 29);
}

std::uint64_t viewId(const std::string& v) { return v == "top" ? 1 : v == "middle" ? 2 : 3; }

void progress(const std::string& view, const WaldBoostStageStats& s, int total, double secs) {
  const int width = 30, filled = s.stage * width / std::max(1, total);
  std::fprintf(stderr,
               "\r[%-6s] %3d/%d |%s%s| pos kept %.3f  neg rejected %.2f  pool %5zu%s  %.0f s   ",
               view.c_str(), s.stage, total, std::string(filled, '#').c_str(),
               std::string(width - filled, ' ').c_str(), s.positives_kept, s.negatives_rejected,
               s.negative_pool, s.refilled ? " (refilled)" : "           ", secs);
}

// Crops the window centred on `centre` (level pixels) from a level, optionally flipped.
bool cropWindow(const cv::Mat& level8, cv::Point2d centre, int W, int H, int dx, int dy, bool flip,
                cv::Mat& out) {
  const int x = static_cast<int>(std::lround(centre.x - W / 2.0)) + dx;
  const int y = static_cast<int>(std::lround(centre.y - H / 2.0)) + dy;
  if (x < 0 || y < 0 || x + W > level8.cols || y + H > level8.rows) return false;
  out = level8(cv::Rect(x, y, W, H)).clone();
  if (flip) cv::flip(out, out, 1);
  return true;
}

int runTrain(const TrainOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto frames = readDataset(o.data);
  const DepthPreprocessParams pre;  // the seed's mapping
  const DepthTo8BitMap to8bit(pre);
  const BowlDetectorParams det;  // pyramid step and search range of the detector
  std::vector<Prepared> prepared(frames.size());
  {
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      for (std::size_t i; (i = next++) < frames.size();) {
        prepared[i].img8 =
            preprocessDepth(readDepth(o.data, frames[i]), to8bit, &prepared[i].filled);
        prepared[i].fx = frames[i].intrinsics.fx;
      }
    };
    std::vector<std::thread> pool;
    for (int i = 0; i < o.threads; ++i) pool.emplace_back(work);
    for (auto& t : pool) t.join();
  }
  // Every frame feeds the bootstrapping; in frames with upright bowls, windows near them are
  // skipped (see the source below).
  std::vector<std::size_t> negatives(frames.size());
  std::iota(negatives.begin(), negatives.end(), std::size_t{0});
  const auto bowl_free =
      std::count_if(frames.begin(), frames.end(), [](const DatasetFrame& f) { return f.negative; });
  spdlog::info(
      "dataset {}: {} frames ({} bowl-free), all used for bootstrapping; preprocessed in {:.1f} s",
      o.data.string(), frames.size(), bowl_free, elapsed(t0));
  fs::create_directories(o.out / ".checkpoints");

  for (const auto& view : o.views) {
    const auto tv = std::chrono::steady_clock::now();
    // Window shape: the median box aspect of this view's training bowls.
    std::vector<double> aspects;
    for (const auto& f : frames)
      for (const auto& b : f.bowls)
        if (b.trainable && b.view == view)
          aspects.push_back(static_cast<double>(b.box.height) / b.box.width);
    if (aspects.empty()) {
      spdlog::warn("no training bowls for view {}", view);
      continue;
    }
    std::nth_element(aspects.begin(), aspects.begin() + aspects.size() / 2, aspects.end());
    const double aspect = aspects[aspects.size() / 2];
    const int W = o.window_width;
    const int H = std::clamp(static_cast<int>(std::lround(W * aspect)), 12, 36);
    const double ow = W * (1 - 2 * o.margin), oh = H * (1 - 2 * o.margin);

    // Positives: each bowl at the pyramid level whose scale best fits it, shifted by up to
    // `jitter` pixels and mirrored (a mirrored table-top scene is as plausible as the scene).
    std::vector<cv::Mat> positives;
    int bowls = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      std::vector<const BowlAnnotation*> mine;
      for (const auto& b : frames[i].bowls)
        if (b.trainable && b.view == view) mine.push_back(&b);
      if (mine.empty()) continue;
      const auto levels = buildBowlPyramid(prepared[i].img8, det.scale_step, W, H);
      for (const auto* b : mine) {
        const double s = std::sqrt(b->box.area() / (ow * oh));
        std::size_t best = 0;
        for (std::size_t k = 1; k < levels.size(); ++k)
          if (std::abs(std::log(levels[k].scale / s)) < std::abs(std::log(levels[best].scale / s)))
            best = k;
        const auto& L = levels[best];
        const cv::Point2d c((b->box.x + b->box.width / 2.0) / L.scale,
                            (b->box.y + b->box.height / 2.0) / L.scale);
        ++bowls;
        for (int dy = -o.jitter; dy <= o.jitter; ++dy)
          for (int dx = -o.jitter; dx <= o.jitter; ++dx) {
            if (dx != 0 && dy != 0) continue;  // a plus shape: 5 positions
            for (bool flip : {false, true}) {
              cv::Mat w;
              if (cropWindow(L.image8, c, W, H, dx, dy, flip, w)) positives.push_back(std::move(w));
            }
          }
      }
    }
    spdlog::info("[{}] window {}x{} (aspect {:.2f}), {} bowls -> {} positives", view, W, H, aspect,
                 bowls, positives.size());

    BowlViewModel model;
    model.view = view;
    model.classifier.win_w = W;
    model.classifier.win_h = H;
    model.object_margin = o.margin;
    model.min_object_width_m = o.min_width_m;
    model.max_object_width_m = o.max_width_m;
    model.preprocess = pre;
    WaldBoostTrainParams tp;
    tp.stages = o.stages;
    tp.target_miss_rate = o.miss_rate;
    tp.negative_pool = o.pool;
    tp.refill_every = o.refill_every;
    json training = {{"tool", "shapesense-train"},
                     {"dataset", json::parse(std::ifstream(o.data / "dataset.json"))},
                     {"seed", o.seed},
                     {"stages", tp.stages},
                     {"target_miss_rate", tp.target_miss_rate},
                     {"negative_pool", tp.negative_pool},
                     {"refill_every", tp.refill_every},
                     {"max_cell", tp.max_cell},
                     {"positives", positives.size()},
                     {"bowls", bowls},
                     {"negative_frames", negatives.size()},
                     {"jitter_px", o.jitter}};

    // Resume from the checkpoint when it was made with the same settings.
    const fs::path ckpt = o.out / ".checkpoints" / ("bowl_" + view + ".json");
    WaldBoostClassifier start = model.classifier;
    if (fs::exists(ckpt)) {
      const auto c = loadBowlModel(ckpt);
      if (json::parse(c.training_json) == training && c.classifier.win_w == W &&
          c.classifier.win_h == H) {
        start = c.classifier;
        spdlog::info("[{}] resuming at stage {}", view, start.stages.size());
      }
    }
    WaldBoostTrainer trainer(positives, start, tp);

    // Bootstrapping source: windows the current classifier accepts, scanned like the detector
    // does (same pyramid and depth gate, stride 1) over all frames in a seeded order, skipping
    // windows whose object box overlaps an upright bowl (IoU > 0.2; upside-down bowls are
    // negatives),
    // at most `cap` per frame so that the pool spreads over many frames.
    auto source = [&](const WaldBoostClassifier& clf, int stage, std::size_t count) {
      BowlViewModel m = model;
      m.classifier = clf;
      std::mt19937_64 rng(mix(mix(o.seed, viewId(view)), static_cast<std::uint64_t>(stage)));
      std::vector<std::size_t> order = negatives;
      std::shuffle(order.begin(), order.end(), rng);
      const std::size_t cap = std::max<std::size_t>(4, count / 60);
      std::vector<cv::Mat> out;
      for (std::size_t b = 0; b < order.size() && out.size() < count;
           b += static_cast<std::size_t>(o.threads)) {
        std::vector<std::future<std::vector<cv::Mat>>> jobs;
        for (std::size_t j = b; j < std::min(order.size(), b + static_cast<std::size_t>(o.threads));
             ++j) {
          jobs.push_back(std::async(std::launch::async, [&, j] {
            const auto& P = prepared[order[j]];
            const auto levels = buildBowlPyramid(P.img8, det.scale_step, W, H);
            std::vector<std::pair<std::size_t, BowlWindowHit>> hits;
            for (std::size_t k = 0; k < levels.size(); ++k) {
              const double obj_px = ow * levels[k].scale;
              if (obj_px < det.min_object_px || obj_px > det.max_object_px) continue;
              // Stride 1 (the detector uses 2): four times the candidate windows.
              for (const auto& h : scanBowlLevel(m, levels[k], P.filled, P.fx, 1, INT32_MIN)) {
                const double sc = levels[k].scale;
                const cv::Rect obj(static_cast<int>((h.x + o.margin * W) * sc),
                                   static_cast<int>((h.y + o.margin * H) * sc),
                                   static_cast<int>(ow * sc), static_cast<int>(oh * sc));
                bool near_bowl = false;
                for (const auto& b : frames[order[j]].bowls)
                  near_bowl |= b.upright && boxIoU(obj, b.box) > 0.2;
                if (!near_bowl) hits.push_back({k, h});
              }
            }
            std::mt19937_64 r(mix(mix(o.seed, static_cast<std::uint64_t>(stage) + 7), order[j]));
            std::shuffle(hits.begin(), hits.end(), r);
            std::vector<cv::Mat> ws;
            for (std::size_t q = 0; q < std::min(cap, hits.size()); ++q) {
              const auto& [k, h] = hits[q];
              ws.push_back(levels[k].image8(cv::Rect(h.x, h.y, W, H)).clone());
            }
            return ws;
          }));
        }
        for (auto& jb : jobs)
          for (auto& w : jb.get())
            if (out.size() < count) out.push_back(std::move(w));
      }
      return out;
    };

    WaldBoostStageStats st;
    while (true) {
      const int t = static_cast<int>(trainer.classifier().stages.size());
      if (t > 0 && trainer.isRefillStage(t)) {
        BowlViewModel c = model;
        c.classifier = trainer.classifier();
        c.training_json = training.dump();
        saveBowlModel(c, ckpt);
      }
      if (!trainer.trainStage(source, &st)) break;
      progress(view, st, tp.stages, elapsed(tv));
    }
    std::fprintf(stderr, "\n");
    model.classifier = trainer.classifier();
    training["stages_trained"] = model.classifier.stages.size();
    training["final_positives_kept"] = st.positives_kept;
    training["final_negative_pool"] = st.negative_pool;
    model.training_json = training.dump();
    saveBowlModel(model, o.out / ("bowl_" + view + ".json"));
    fs::remove(ckpt);
    spdlog::info("[{}] {} stages in {:.1f} s -> {}", view, model.classifier.stages.size(),
                 elapsed(tv), (o.out / ("bowl_" + view + ".json")).string());
  }
  fs::remove_all(o.out / ".checkpoints");
  spdlog::info("training done in {:.1f} s", elapsed(t0));
  return 0;
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"shapesense-train: WaldBoost/LBP bowl detector training and evaluation"};
  app.require_subcommand(1);

  GenerateParams gp;
  fs::path gen_out;
  auto* gen = app.add_subcommand("generate", "render a synthetic bowl dataset");
  gen->add_option("--out", gen_out, "dataset folder")->required();
  gen->add_option("--seed", gp.seed, "scene seed base");
  gen->add_option("--positive-scenes", gp.positive_scenes, "scenes with upright bowls");
  gen->add_option("--negative-scenes", gp.negative_scenes, "scenes without upright bowls");
  gen->add_option("--frames-per-scene", gp.frames_per_scene);
  gen->add_option("--blank-room", gp.blank_room_fraction,
                  "fraction of frames whose room reads no depth");
  gen->add_option("--threads", gp.threads);

  TrainOptions to;
  std::string views = "top,middle,side";
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
  tr->add_option("--views", views);
  tr->add_option("--threads", to.threads);

  fs::path models, data;
  BowlDetectorParams dp;
  // Scan options of eval and diagnose (defaults: BowlDetectorParams).
  auto scanOptions = [&dp](CLI::App* a) {
    a->add_option("--threshold", dp.score_threshold,
                  "final score threshold (default: the models' operating point)");
    a->add_option("--scale-step", dp.scale_step, "pyramid scale step");
    a->add_option("--stride", dp.stride, "window stride (level pixels)");
    a->add_option("--nms-overlap", dp.nms_max_overlap, "NMS inscribed-circle overlap");
    a->add_option("--merge-iou", dp.box_merge_iou,
                  "box = mean of accepted windows with this IoU (0 = off)");
    a->add_option("--support-weight", dp.support_score_weight,
                  "score += weight * ln(windows merged into the box) (0 = off)");
    a->add_flag("!--no-depth-gate", dp.depth_gate, "classify every window whatever the depth");
  };
  bool verbose = false;
  auto* ev = app.add_subcommand("eval", "AP50 and miss rate at 0.1 FPPI on a dataset");
  ev->add_option("--models", models)->required();
  ev->add_option("--data", data)->required();
  scanOptions(ev);
  ev->add_flag("--verbose", verbose);
  fs::path raw_out;
  ev->add_option("--raw-out", raw_out,
                 "write every accepted window before NMS and the truth (JSON lines)");
  auto* dg = app.add_subcommand(
      "diagnose", "why each missed bowl is missed (classifier, box calibration or NMS)");
  dg->add_option("--models", models)->required();
  dg->add_option("--data", data)->required();
  scanOptions(dg);
  auto* re = app.add_subcommand("real", "print detections on a TUM recording");
  re->add_option("--models", models)->required();
  std::vector<fs::path> recordings;
  re->add_option("--tum", recordings, "TUM recording folders")->required();
  re->add_option("--threshold", dp.score_threshold,
                 "final score threshold (default: the models' operating point)");
  BowlVerification verification;
  for (auto* a : {ev, re}) {
    auto& g = verification.params;
    a->add_flag("!--no-verify", verification.on,
                "the classifier's detections, without the 3D check");
    a->add_option("--unverified-score", verification.min_unverified_score,
                  "3D check: score keeping a detection the depth cannot settle");
    a->add_option("--min-rim-to-foot", g.min_rim_to_foot_width, "3D check: rim over foot width");
    a->add_option("--height-ratio-min", g.min_height_to_diameter, "3D check: height / rim, min");
    a->add_option("--height-ratio-max", g.max_height_to_diameter, "3D check: height / rim, max");
    a->add_option("--band-fraction", g.band_fraction, "3D check: rim / foot band share");
  }

  WbDetectorExportParams wp;
  fs::path wb_data, wb_out;
  std::string wb_views = "top,middle,side";
  auto* wb = app.add_subcommand("export-wbdetector",
                                "positive crops and bowl-free images for OpenCV's WBDetector");
  wb->add_option("--data", wb_data, "dataset folder")->required();
  wb->add_option("--out", wb_out, "output folder (one subfolder per view)")->required();
  wb->add_option("--views", wb_views);
  wb->add_option("--max-bowls", wp.max_bowls_per_view, "bowls per view used as positives");
  wb->add_option("--target-positives", wp.target_positives,
                 "positives per view (shifted / mirrored variants)");

  CLI11_PARSE(app, argc, argv);
  try {
    if (gen->parsed()) {
      generateDataset(gen_out, gp);
      return 0;
    }
    if (tr->parsed()) {
      to.views.clear();
      std::stringstream ss(views);
      for (std::string v; std::getline(ss, v, ',');) to.views.push_back(v);
      return runTrain(to);
    }
    if (verbose) spdlog::set_level(spdlog::level::debug);
    if (ev->parsed()) return runEval(models, data, dp, verification, verbose, raw_out);
    if (dg->parsed()) return runDiagnose(models, data, dp);
    if (re->parsed()) return runReal(models, recordings, dp, verification);
    if (wb->parsed()) {
      wp.views.clear();
      std::stringstream ss(wb_views);
      for (std::string v; std::getline(ss, v, ',');) wp.views.push_back(v);
      exportWbDetectorData(wb_data, wb_out, wp);
      return 0;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
