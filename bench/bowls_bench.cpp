// Bowl detector timing: one 640x480 synthetic Kinect frame, one thread, all three views
// (shipped models), plus the preprocessing alone.
//
// Accuracy beside a public peer, same run, same frames, same scoring (bowl_eval.h: AP50, miss
// rate at 0.1 false positives per frame): BM_BowlTestSet/* runs our detector and OpenCV's
// cv::xobjdetect::WBDetector (SHAPESENSE_BENCH_OPENCV_XOBJDETECT) on the held-out synthetic test
// set (scripts/train-bowls: seed 9001, never used in training), with the per-frame thread CPU
// median. WBDetector is trained on the same synthetic training set as our models (seed 1), one
// detector per view as ours; bench/prepare-bowl-peer renders the data and exports it as the image
// folders WBDetector trains from (shapesense-train export-wbdetector), and the first run of this
// benchmark trains the three views and caches the models in the build dir
// (<build>/bowl-peer/<view>/model.yml). Without the data, BM_BowlTestSet reports an error.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#ifdef SHAPESENSE_BENCH_OPENCV_XOBJDETECT
#include <opencv2/xobjdetect.hpp>

#include "wbdetector_export.h"
#endif

#include "dataset.h"

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/core/bowls/depth_preprocess.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/driver/tum_recording.h"

namespace {

std::filesystem::path shippedModels() {
  return std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
}

const shapesense::synthetic::RenderedFrame& frame() {
  static const auto f = [] {
    shapesense::synthetic::SceneParams p;
    p.seed = 31337;  // not a training seed
    p.render_colour = false;
    p.camera_height_min_m = 1.3;
    p.camera_height_max_m = 1.6;
    p.table_distance_min_m = 1.1;
    p.table_distance_max_m = 1.8;
    p.min_table_elevation_deg = 17.0;
    return shapesense::synthetic::SyntheticScene(p).render(0, 0);
  }();
  return f;
}

void BM_BowlDetect(benchmark::State& state) {
  cv::setNumThreads(1);  // one thread, OpenCV's resize/integral included
  const auto detector = shapesense::BowlDetector::load(shippedModels());
  const auto& f = frame();
  std::size_t n = 0;
  for (auto _ : state) {
    auto d = detector.detect(f.frame.depth, f.frame.intrinsics);
    n = d.size();
    benchmark::DoNotOptimize(d);
  }
  state.counters["detections"] = static_cast<double>(n);
}
BENCHMARK(BM_BowlDetect)->Unit(benchmark::kMillisecond);

// One view at a time, to see where the time goes.
void BM_BowlDetectOneView(benchmark::State& state) {
  cv::setNumThreads(1);
  static const char* views[] = {"top", "middle", "side"};
  shapesense::BowlDetectorParams p;
  p.views = {views[state.range(0)]};
  const auto detector = shapesense::BowlDetector::load(shippedModels(), p);
  const auto& f = frame();
  for (auto _ : state) benchmark::DoNotOptimize(detector.detect(f.frame.depth, f.frame.intrinsics));
  state.SetLabel(views[state.range(0)]);
}
BENCHMARK(BM_BowlDetectOneView)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

void BM_BowlPreprocess(benchmark::State& state) {
  cv::setNumThreads(1);
  const auto& f = frame();
  // The detector's path: the 8-bit table is built once, not per frame.
  const shapesense::DepthTo8BitMap map{shapesense::DepthPreprocessParams{}};
  for (auto _ : state) {
    cv::Mat filled;
    auto m = shapesense::preprocessDepth(f.frame.depth, map, &filled);
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_BowlPreprocess)->Unit(benchmark::kMillisecond);

// Real Kinect-class frames: every depth frame of every recording in shared/data/real (none of
// them trained on), at each recording's own intrinsics and depth scale, cycled. Synthetic test
// frames include rooms that read no depth at all, where the hole fill dominates; real frames
// show what the daemon pays on a sensor.
struct RealFrame {
  cv::Mat depth_mm;
  shapesense::CameraIntrinsics intrinsics;
};

const std::vector<RealFrame>& realFrames() {
  static const std::vector<RealFrame> all = [] {
    std::vector<RealFrame> out;
    const auto root = std::filesystem::path(SHAPESENSE_SHARED_DIR) / "data/real";
    if (!std::filesystem::is_directory(root)) return out;
    std::vector<std::filesystem::path> dirs;
    for (const auto& e : std::filesystem::directory_iterator(root))
      if (std::filesystem::exists(e.path() / "depth.txt")) dirs.push_back(e.path());
    std::sort(dirs.begin(), dirs.end());
    for (const auto& dir : dirs) {
      const auto index = shapesense::readTumIndex(dir);
      for (const auto& entry : index.depth) {
        const cv::Mat raw = cv::imread((dir / entry.relative_path).string(), cv::IMREAD_UNCHANGED);
        if (raw.type() != CV_16UC1) continue;
        cv::Mat mm;
        raw.convertTo(mm, CV_16UC1, 1000.0 / index.camera.depth_scale);
        out.push_back({mm, index.camera.intrinsics});
      }
    }
    return out;
  }();
  return all;
}

void BM_BowlDetectReal(benchmark::State& state) {
  cv::setNumThreads(1);
  const auto& frames = realFrames();
  if (frames.empty()) {
    state.SkipWithError("no real recordings: expected ../shared/data/real beside the repository");
    return;
  }
  const auto detector = shapesense::BowlDetector::load(shippedModels());
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& f = frames[i++ % frames.size()];
    benchmark::DoNotOptimize(detector.detect(f.depth_mm, f.intrinsics));
  }
  state.counters["frames"] = static_cast<double>(frames.size());
}
BENCHMARK(BM_BowlDetectReal)->Unit(benchmark::kMillisecond);

// The bowl stage as the daemon runs it: the classifier, then the 3D check of its detections
// (keepBowlShaped) on the planes of the same frame. The planes are computed outside the timed
// loop: they are the plane stage's product, which the bowl stage reuses.
void runBowlStage(benchmark::State& state, const std::vector<RealFrame>& frames) {
  cv::setNumThreads(1);
  if (frames.empty()) {
    state.SkipWithError("no frames: expected ../shared/data/real beside the repository");
    return;
  }
  const auto detector = shapesense::BowlDetector::load(shippedModels());
  shapesense::HoughPlaneDetector plane_detector;
  std::vector<shapesense::PlaneDetection> planes;
  for (const auto& f : frames) planes.push_back(plane_detector.detect(f.depth_mm, f.intrinsics));
  const double unverified = detector.operatingPoint().unverified_score_threshold;
  std::size_t i = 0, kept = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % frames.size();
    const auto& f = frames[k];
    auto bowls = shapesense::keepBowlShaped(detector.detect(f.depth_mm, f.intrinsics), f.depth_mm,
                                            f.intrinsics, planes[k], {}, unverified);
    kept += bowls.size();
    benchmark::DoNotOptimize(bowls);
  }
  state.counters["frames"] = static_cast<double>(frames.size());
  state.counters["bowls_per_frame"] =
      static_cast<double>(kept) / static_cast<double>(std::max<std::size_t>(1, i));
}

void BM_BowlStage(benchmark::State& state) {
  const auto& f = frame();
  runBowlStage(state, {{f.frame.depth, f.frame.intrinsics}});
}
BENCHMARK(BM_BowlStage)->Unit(benchmark::kMillisecond);

void BM_BowlStageReal(benchmark::State& state) { runBowlStage(state, realFrames()); }
BENCHMARK(BM_BowlStageReal)->Unit(benchmark::kMillisecond);

// ---- Held-out test set: ours beside WBDetector ----

namespace fs = std::filesystem;
using BowlDetectFn = std::function<std::vector<shapesense::BowlDetection>(
    const cv::Mat&, const shapesense::CameraIntrinsics&)>;

fs::path testSetDir() { return fs::path(SHAPESENSE_BINARY_DIR) / "bowl-data" / "test"; }

double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

struct TestFrame {
  cv::Mat depth;
  shapesense::CameraIntrinsics intrinsics;
  std::vector<shapesense::BowlTruthBox> truth;
  std::vector<std::string> views;  ///< view class of each truth box
};

const std::vector<TestFrame>& testSet() {
  static const std::vector<TestFrame> all = [] {
    std::vector<TestFrame> out;
    if (!fs::exists(testSetDir() / "annotations.jsonl")) return out;
    try {
      shapesense::train::requireEvaluationTruth(testSetDir());
    } catch (const std::exception& e) {  // a stale test set: rerun bench/prepare-bowl-peer
      std::fprintf(stderr, "%s\n", e.what());
      return out;
    }
    for (const auto& f : shapesense::train::readDataset(testSetDir())) {
      TestFrame t{shapesense::train::readDepth(testSetDir(), f), f.intrinsics, {}, {}};
      // As shapesense-train eval: upright bowls are the truth, difficult ones are ignored.
      for (const auto& b : f.bowls)
        if (b.upright) {
          t.truth.push_back({b.box, b.difficult});
          t.views.push_back(b.view);
        }
      out.push_back(std::move(t));
    }
    return out;
  }();
  return all;
}

// Accuracy and per-frame CPU over the whole test set once, then the timed loop cycles frames.
void runTestSet(benchmark::State& state, const char* name, const BowlDetectFn& detect) {
  const auto& frames = testSet();
  if (frames.empty()) {
    state.SkipWithError("no current test set: run bench/prepare-bowl-peer BUILD_DIR");
    return;
  }
  std::vector<shapesense::BowlEvalFrame> eval;
  std::vector<double> ms;
  for (const auto& f : frames) {
    const double t0 = threadCpuMs();
    auto dets = detect(f.depth, f.intrinsics);
    ms.push_back(threadCpuMs() - t0);
    eval.push_back({std::move(dets), f.truth});
  }
  std::sort(ms.begin(), ms.end());
  const auto r = shapesense::evaluateBowlDetections(eval, 0.5, 0.1);
  // Recall per view class (any detection with IoU >= 0.5), as shapesense-train eval prints it.
  // Also all views at IoU >= 0.3: tells localisation misses from bowls not found at all.
  std::map<std::string, std::pair<int, int>> per_view;
  int loose = 0, total = 0;
  for (std::size_t k = 0; k < frames.size(); ++k)
    for (std::size_t t = 0; t < frames[k].truth.size(); ++t) {
      if (frames[k].truth[t].difficult) continue;
      auto& pv = per_view[frames[k].views[t]];
      ++pv.second;
      ++total;
      double best = 0;
      for (const auto& d : eval[k].detections)
        best = std::max(best, shapesense::boxIoU(d.box, frames[k].truth[t].box));
      pv.first += best >= 0.5;
      loose += best >= 0.3;
    }
  std::string recalls;
  for (const auto& [v, c] : per_view)
    recalls += " " + v + " " + std::to_string(c.first) + "/" + std::to_string(c.second);
  recalls += "; all views @IoU0.3 " + std::to_string(loose) + "/" + std::to_string(total);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& f = frames[i++ % frames.size()];
    benchmark::DoNotOptimize(detect(f.depth, f.intrinsics));
  }
  const double median_ms = ms[ms.size() / 2];
  std::printf(
      "[%-14s] %d test frames, %d bowls: AP50 %.3f, miss rate @0.1 FPPI %.3f, max recall %.3f, TP "
      "%d FP %d, median %.2f ms/frame (CPU); recall@IoU0.5 by view:%s\n",
      name, r.frames, r.positives, r.ap, r.miss_rate_at_fppi, r.max_recall, r.true_positives,
      r.false_positives, median_ms, recalls.c_str());
  state.counters["AP50"] = r.ap;
  state.counters["miss_rate"] = r.miss_rate_at_fppi;
  state.counters["median_cpu_ms"] = median_ms;
}

void BM_BowlTestSet_Ours(benchmark::State& state) {
  cv::setNumThreads(1);
  const auto detector = shapesense::BowlDetector::load(shippedModels());
  runTestSet(state, "ours", [&](const cv::Mat& d, const shapesense::CameraIntrinsics& K) {
    return detector.detect(d, K);
  });
}
BENCHMARK(BM_BowlTestSet_Ours)->Unit(benchmark::kMillisecond)->Iterations(20);

#ifdef SHAPESENSE_BENCH_OPENCV_XOBJDETECT
/// OpenCV's WBDetector, one per view, on our preprocessed 8-bit depth (see wbdetector_export.h
/// for the per-view vertical stretch that makes bowls square for its 24x24 window).
struct WbDetectorPeerParams {
  /// WBDetector scans windows of 20-120 px only (its scales 0.2-1.2 are built in); a second pass
  /// on the half-size image covers windows of 120-240 px (objects up to 180 px; the test set's
  /// widest bowl is ~200 px). Only its windows above 120 px are kept, so the bands do not overlap.
  bool second_band = true;
  int band_split_px = 120;
  /// Greedy non-maximum suppression across views and bands (the detector groups windows within
  /// one call only). Default IoU 0.5, the evaluation's match threshold.
  double nms_iou = 0.5;
  /// Views to run (all three, as ours). Default top, middle, side.
  std::vector<std::string> views = {"top", "middle", "side"};
};

// WBDetector's trainer sets a weak classifier's weight to 0.5 log((1 - err) / err) without
// guarding err = 0: when a stump separates the remaining samples perfectly (it does on the top
// view, whose bowls random depth windows rarely resemble) the weight and the cascade threshold
// become NaN / inf and the saved detector rejects every window. Such a model is cut before
// its first non-finite weak classifier (the prefix is what the training had achieved) and the
// cut is reported. Returns the number of weak classifiers kept, or -1 when nothing was cut.
int truncateNonFiniteWeakClassifiers(const fs::path& model) {
  cv::FileStorage in(model.string(), cv::FileStorage::READ);
  const cv::FileNode root = in.getFirstTopLevelNode();
  const int count = static_cast<int>(root["waldboost_params"]["weak_count"]);
  const char* fields[] = {"thresholds", "alphas", "polarities", "cascade_thresholds",
                          "feature_indices"};
  std::vector<std::vector<double>> values(5);
  for (int f = 0; f < 5; ++f)
    for (const auto& v : root[fields[f]]) values[f].push_back(static_cast<double>(v));
  int keep = count;
  for (int i = 0; i < count; ++i)
    if (!std::isfinite(values[1].at(i)) || !std::isfinite(values[3].at(i))) {
      keep = i;
      break;
    }
  if (keep == count) return -1;
  in.release();
  cv::FileStorage out(model.string(), cv::FileStorage::WRITE);
  out << "waldboost"
      << "{"
      << "waldboost_params"
      << "{"
      << "weak_count" << keep << "}";
  for (int f = 0; f < 5; ++f) {
    out << fields[f] << "[";
    for (int i = 0; i < keep; ++i) {
      if (f == 2 || f == 4)
        out << static_cast<int>(values[f][i]);
      else
        out << static_cast<float>(values[f][i]);
    }
    out << "]";
  }
  out << "}";
  return keep;
}

class WbDetectorPeer {
 public:
  /// Loads <dir>/<view>/model.yml, training and caching it first when missing. Throws when the
  /// exported data is missing.
  static WbDetectorPeer loadOrTrain(const fs::path& dir, WbDetectorPeerParams params = {}) {
    WbDetectorPeer peer;
    peer.params_ = params;
    for (const auto& view_name : params.views) {
      const char* view = view_name.c_str();
      const fs::path vd = dir / view;
      View v;
      v.name = view;
      v.meta = shapesense::train::readWbDetectorMeta(vd / "meta.yml");
      v.detector = cv::xobjdetect::WBDetector::create();
      const fs::path model = vd / "model.yml";
      if (!fs::exists(model)) {
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = threadCpuMs();
        v.detector->train((vd / "pos").string(), (vd / "neg").string());
        cv::FileStorage out(model.string(), cv::FileStorage::WRITE);
        out << "waldboost";
        v.detector->write(out);
        std::printf("[wbdetector] trained view %s in %.0f s (%.0f s CPU) -> %s\n", view,
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                    (threadCpuMs() - c0) / 1e3, model.string().c_str());
      }
      if (const int kept = truncateNonFiniteWeakClassifiers(model); kept >= 0)
        std::printf(
            "[wbdetector] view %s: non-finite weight after %d weak classifiers (zero-error stump); "
            "model cut to those %d\n",
            view, kept, kept);
      cv::FileStorage in(model.string(), cv::FileStorage::READ);
      if (!in.isOpened()) throw std::runtime_error("cannot read " + model.string());
      v.detector->read(in.getFirstTopLevelNode());
      peer.views_.push_back(std::move(v));
    }
    return peer;
  }

  std::vector<shapesense::BowlDetection> detect(const cv::Mat& depth_mm) const {
    const cv::Mat img8 = shapesense::preprocessDepth(depth_mm, to8bit_);
    std::vector<shapesense::BowlDetection> all;
    for (const auto& v : views_) {
      const cv::Mat img = shapesense::train::stretchForView(img8, v.meta);
      auto add = [&](const cv::Mat& im, double scale, int min_side) {
        std::vector<cv::Rect> boxes;
        std::vector<double> conf;
        v.detector->detect(im, boxes, conf);
        for (std::size_t k = 0; k < boxes.size(); ++k) {
          const cv::Rect w(cvRound(boxes[k].x * scale), cvRound(boxes[k].y * scale),
                           cvRound(boxes[k].width * scale), cvRound(boxes[k].height * scale));
          if (w.width > min_side)
            all.push_back({shapesense::train::windowToObjectBox(w, v.meta), conf[k], v.name});
        }
      };
      add(img, 1.0, 0);
      if (params_.second_band) {
        cv::Mat half;
        cv::resize(img, half, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
        add(half, 2.0, params_.band_split_px);
      }
    }
    std::sort(all.begin(), all.end(),
              [](const auto& a, const auto& b) { return a.score > b.score; });
    std::vector<shapesense::BowlDetection> kept;
    for (auto& d : all) {
      bool suppressed = false;
      for (const auto& k : kept) suppressed |= shapesense::boxIoU(d.box, k.box) > params_.nms_iou;
      if (!suppressed) kept.push_back(std::move(d));
    }
    return kept;
  }

 private:
  struct View {
    std::string name;
    shapesense::train::WbDetectorMeta meta;
    cv::Ptr<cv::xobjdetect::WBDetector> detector;
  };
  std::vector<View> views_;
  shapesense::DepthTo8BitMap to8bit_{shapesense::DepthPreprocessParams{}};  // as our models
  WbDetectorPeerParams params_;
};

void BM_BowlTestSet_WbDetector(benchmark::State& state) {
  cv::setNumThreads(1);
  const fs::path dir = fs::path(SHAPESENSE_BINARY_DIR) / "bowl-peer";
  if (!fs::exists(dir / "side" / "meta.yml")) {
    state.SkipWithError("no WBDetector training data: run bench/prepare-bowl-peer BUILD_DIR");
    return;
  }
  static const WbDetectorPeer peer = WbDetectorPeer::loadOrTrain(dir);  // trained once per process
  runTestSet(state, "wbdetector",
             [&](const cv::Mat& d, const shapesense::CameraIntrinsics&) { return peer.detect(d); });
}
BENCHMARK(BM_BowlTestSet_WbDetector)->Unit(benchmark::kMillisecond)->Iterations(5);

// The same without the top view, whose WBDetector training breaks down (see
// truncateNonFiniteWeakClassifiers): shows what the cut top model costs or adds.
void BM_BowlTestSet_WbDetectorNoTop(benchmark::State& state) {
  cv::setNumThreads(1);
  const fs::path dir = fs::path(SHAPESENSE_BINARY_DIR) / "bowl-peer";
  if (!fs::exists(dir / "side" / "meta.yml")) {
    state.SkipWithError("no WBDetector training data: run bench/prepare-bowl-peer BUILD_DIR");
    return;
  }
  WbDetectorPeerParams p;
  p.views = {"middle", "side"};
  static const WbDetectorPeer peer = WbDetectorPeer::loadOrTrain(dir, p);
  runTestSet(state, "wbdet_mid+side",
             [&](const cv::Mat& d, const shapesense::CameraIntrinsics&) { return peer.detect(d); });
}
BENCHMARK(BM_BowlTestSet_WbDetectorNoTop)->Unit(benchmark::kMillisecond)->Iterations(5);
#endif

}  // namespace
