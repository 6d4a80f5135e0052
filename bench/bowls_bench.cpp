// Bowl detector timing: one 640x480 synthetic Kinect frame, one thread, all three views
// (shipped models), plus the preprocessing alone. The OpenCV xobjdetect WBDetector peer is not
// measured: see the comment at the end (SHAPESENSE_BENCH_OPENCV_XOBJDETECT).
#include <filesystem>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include "shapesense/core/bowl_detector.h"
#include "shapesense/core/depth_preprocess.h"
#include "shapesense/driver/synthetic_scene.h"

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
  for (auto _ : state) {
    cv::Mat filled;
    auto m = shapesense::preprocessDepth(f.frame.depth, shapesense::DepthPreprocessParams{}, &filled);
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_BowlPreprocess)->Unit(benchmark::kMillisecond);

// Peer: cv::xobjdetect::WBDetector (OpenCV 4.6 contrib) trains from a folder of positive
// crops and a folder of negative images with its own ACF-like features and a fixed cascade
// schedule; feeding it our 8-bit depth crops is possible but its training was not run within
// this time budget, so no peer figure is reported (see the issue report).

}  // namespace

BENCHMARK_MAIN();
