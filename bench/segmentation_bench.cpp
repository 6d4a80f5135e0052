// Normals and depth segmentation at 640x480, one thread: one benchmark per normal mode and per
// segmentation method, on a synthetic Kinect frame (SyntheticScene seed 1, frame 0) and on the
// real mosd_tabletop frames (cycled). Issue 3 targets: normals <= 2 ms, depth_step <= 3 ms, the
// other methods <= 10 ms.
//
// Run: segmentation_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// The machine is shared: compare against the reference benchmark (BM_Reference_BoxFilter, a fixed
// amount of OpenCV work) of the same run rather than across runs.
//
// OpenCV's cv::rgbd::RgbdNormals (FALS) peer is compiled only with SHAPESENSE_BENCH_OPENCV_RGBD
// defined and opencv_rgbd linked (the bench target links core/imgproc/imgcodecs only).
// PCL peers (SHAPESENSE_BENCH_PCL, bench/CMakeLists.txt): pcl::IntegralImageNormalEstimation in
// its four modes (BM_PclNormals; the depth-to-cloud conversion is not timed, as depthTo3d for
// OpenCV), and pcl::OrganizedMultiPlaneSegmentation on precomputed normals (BM_PclOmpsSegment,
// the segmentation alone; plane_peers.h has its parameters).
//
// Accuracy: on the synthetic frame every segmenter (ours and OMPS) also reports the SegComp pixel
// accuracy against the truth surfaces (counter pixel_acc, see segmentation_scoring.h), computed
// once outside the timed loop.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#ifdef SHAPESENSE_BENCH_OPENCV_RGBD
#include <opencv2/rgbd.hpp>
#endif

#include "plane_peers.h"
#include "shapesense/core/normals/normals.h"
#include "shapesense/core/segmentation/segment_statistics.h"
#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/server/frame_memory.h"

namespace shapesense {
namespace {

struct Frames {
  std::vector<cv::Mat> synthetic;  // CV_16UC1 mm
  std::vector<cv::Mat> mosd;       // CV_16UC1 mm
  cv::Mat synthetic_truth;         // CV_16UC1 truth surface ids of synthetic[0]
  CameraIntrinsics intrinsics;
};

const Frames& frames() {
  static const Frames f = [] {
    Frames out;
    synthetic::SceneParams p;
    p.seed = 1;
    p.render_colour = false;
    const synthetic::SyntheticScene scene(p);
    const auto r = scene.render(0, 0);
    out.synthetic.push_back(r.frame.depth.clone());
    out.synthetic_truth = r.truth.surface_labels.clone();
    out.intrinsics = r.frame.intrinsics;
    const std::filesystem::path dir =
        std::filesystem::path(SHAPESENSE_SHARED_DIR) / "data/real/mosd_tabletop";
    std::ifstream list(dir / "depth.txt");
    std::string line;
    while (std::getline(list, line)) {
      if (line.empty() || line[0] == '#') continue;
      const cv::Mat raw =
          cv::imread((dir / line.substr(line.find(' ') + 1)).string(), cv::IMREAD_UNCHANGED);
      if (raw.empty()) continue;
      cv::Mat mm;
      raw.convertTo(mm, CV_16UC1, 0.2);  // 5000 units per metre -> mm
      out.mosd.push_back(mm);
    }
    return out;
  }();
  return f;
}

const std::vector<cv::Mat>& source(int which) {
  return which == 0 ? frames().synthetic : frames().mosd;
}

void BM_Reference_BoxFilter(benchmark::State& state) {
  const cv::Mat& d = frames().synthetic[0];
  cv::Mat f, out;
  d.convertTo(f, CV_32F);
  for (auto _ : state) {
    cv::boxFilter(f, out, CV_32F, cv::Size(11, 11));
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_Reference_BoxFilter)->Unit(benchmark::kMillisecond);

void BM_Normals(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(1)));
  if (src.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  NormalParams p;
  p.method = static_cast<NormalMethod>(state.range(0));
  NormalEstimator est(p);
  cv::Mat normals;
  std::size_t i = 0;
  for (auto _ : state) {
    est.compute(src[i++ % src.size()], frames().intrinsics, normals);
    benchmark::DoNotOptimize(normals.data);
  }
}
BENCHMARK(BM_Normals)
    ->ArgNames({"method", "mosd"})
    ->ArgsProduct({{static_cast<int>(NormalMethod::kCovariance),
                    static_cast<int>(NormalMethod::kAverage3dGradient),
                    static_cast<int>(NormalMethod::kAverageDepthChange)},
                   {0, 1}})
    ->Unit(benchmark::kMillisecond);

void BM_Segment(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(1)));
  if (src.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  const auto m = static_cast<SegmentationMethod>(state.range(0));
  state.SetLabel(std::string(formatSegmentationMethod(m)));
  const SegmentationParams params;
  if (state.range(1) == 0)
    state.counters["pixel_acc"] =
        scoreSegmentation(segmentDepth(src[0], frames().intrinsics, m, params),
                          frames().synthetic_truth)
            .pixel_accuracy;
  std::size_t i = 0;
  for (auto _ : state) {
    cv::Mat r = segmentDepth(src[i++ % src.size()], frames().intrinsics, m, params);
    benchmark::DoNotOptimize(r.data);
  }
}
BENCHMARK(BM_Segment)
    ->ArgNames({"method", "mosd"})
    ->ArgsProduct({{static_cast<int>(SegmentationMethod::kDepthStep),
                    static_cast<int>(SegmentationMethod::kNormalEdges),
                    static_cast<int>(SegmentationMethod::kFused),
                    static_cast<int>(SegmentationMethod::kPlanePrediction),
                    static_cast<int>(SegmentationMethod::kTiledRansac),
                    static_cast<int>(SegmentationMethod::kPlanesAndObjects)},
                   {0, 1}})
    ->Unit(benchmark::kMillisecond);

// The default segmentation as the daemon runs it: after the plane stage, on its planes (the
// plane detection is made once per frame outside the timed loop; BM_Segment's planes_objects
// row includes it). joins 0: without joining the pieces of faces and of curved objects, nor
// splitting creased regions.
void BM_SegmentWithPlanes(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(0)));
  if (src.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  HoughPlaneDetector hough;
  std::vector<PlaneDetection> planes;
  for (const auto& depth : src) planes.push_back(hough.detect(depth, frames().intrinsics));
  SegmentationParams params;
  params.planes_and_objects.join_face_parts = state.range(1) != 0;
  params.planes_and_objects.join_curved_objects = state.range(1) != 0;
  params.planes_and_objects.split_creased_objects = state.range(1) != 0;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % src.size();
    cv::Mat r = segmentWithPlanes(src[k], frames().intrinsics,
                                  SegmentationMethod::kPlanesAndObjects, planes[k], params);
    benchmark::DoNotOptimize(r.data);
  }
}
BENCHMARK(BM_SegmentWithPlanes)
    ->ArgNames({"mosd", "joins"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

// Per-segment statistics (the daemon's segmentation stage runs them after segmentDepth) of the
// depth_step regions of each frame, segmented outside the timed loop.
void BM_SegmentStatistics(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(0)));
  if (src.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  std::vector<cv::Mat> regions;
  for (const cv::Mat& d : src)
    regions.push_back(segmentDepth(d, frames().intrinsics, SegmentationMethod::kDepthStep));
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % src.size();
    auto stats = computeSegmentStatistics(regions[k], src[k], frames().intrinsics);
    benchmark::DoNotOptimize(stats.data());
  }
}
BENCHMARK(BM_SegmentStatistics)->ArgNames({"mosd"})->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

#ifdef SHAPESENSE_BENCH_OPENCV_RGBD
void BM_OpenCvRgbdNormalsFals(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(0)));
  const CameraIntrinsics& K = frames().intrinsics;
  const cv::Matx33f Km(K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
  cv::rgbd::RgbdNormals est(480, 640, CV_32F, cv::Mat(Km), 5,
                            cv::rgbd::RgbdNormals::RGBD_NORMALS_METHOD_FALS);
  cv::Mat points, normals;
  std::size_t i = 0;
  for (auto _ : state) {
    state.PauseTiming();
    cv::rgbd::depthTo3d(src[i++ % src.size()], cv::Mat(Km), points);
    state.ResumeTiming();
    est(points, normals);
    benchmark::DoNotOptimize(normals.data);
  }
}
BENCHMARK(BM_OpenCvRgbdNormalsFals)
    ->ArgNames({"mosd"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);
#endif

#ifdef SHAPESENSE_BENCH_PCL
using PclNormalEstimation = pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal>;

// PCL's integral image normals in each mode, with the settings of PCL's normal estimation
// tutorial (max depth change factor 0.02, smoothing size 10 px) for all of them.
void BM_PclNormals(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(1)));
  if (src.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  static const char* names[] = {"covariance", "average_3d_gradient", "average_depth_change",
                                "simple_3d_gradient"};
  state.SetLabel(names[state.range(0)]);
  PclNormalEstimation ne;
  ne.setNormalEstimationMethod(
      static_cast<PclNormalEstimation::NormalEstimationMethod>(state.range(0)));
  ne.setMaxDepthChangeFactor(0.02f);
  ne.setNormalSmoothingSize(10.0f);
  pcl::PointCloud<pcl::Normal> normals;
  std::size_t i = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const auto cloud = peers::toPclCloud(src[i++ % src.size()], frames().intrinsics);
    state.ResumeTiming();
    ne.setInputCloud(cloud);
    ne.compute(normals);
    benchmark::DoNotOptimize(normals.points.data());
  }
}
BENCHMARK(BM_PclNormals)
    ->ArgNames({"method", "mosd"})
    ->ArgsProduct(
        {{PclNormalEstimation::COVARIANCE_MATRIX, PclNormalEstimation::AVERAGE_3D_GRADIENT,
          PclNormalEstimation::AVERAGE_DEPTH_CHANGE, PclNormalEstimation::SIMPLE_3D_GRADIENT},
         {0, 1}})
    ->Unit(benchmark::kMillisecond);

// OrganizedMultiPlaneSegmentation (with refinement) on normals computed beforehand: the time
// after normals. Its labels are planes only; everything else stays unassigned (0).
void BM_PclOmpsSegment(benchmark::State& state) {
  const auto& src = source(static_cast<int>(state.range(0)));
  if (src.empty()) {
    state.SkipWithError("no frames");
    return;
  }
  peers::PclOmpsDetector omps;
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> clouds;
  std::vector<pcl::PointCloud<pcl::Normal>::Ptr> normals;
  for (const auto& d : src) {
    clouds.push_back(peers::toPclCloud(d, frames().intrinsics));
    normals.push_back(omps.normals(clouds.back()));
  }
  if (state.range(0) == 0)
    state.counters["pixel_acc"] =
        scoreSegmentation(omps.segment(clouds[0], normals[0]).labels, frames().synthetic_truth)
            .pixel_accuracy;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % src.size();
    PlaneDetection r = omps.segment(clouds[k], normals[k]);
    benchmark::DoNotOptimize(r.labels.data);
  }
}
BENCHMARK(BM_PclOmpsSegment)->ArgNames({"mosd"})->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
#endif

}  // namespace
}  // namespace shapesense

// One thread for OpenCV too (its box filters and peers would otherwise use the pool), so every
// figure is single-threaded work.
int main(int argc, char** argv) {
  shapesense::keepFrameBuffersAllocated();  // the daemon's memory policy
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
