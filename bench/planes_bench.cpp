// Plane detection per 640x480 frame: normals + Hough detector vs the sequential RANSAC baseline,
// on 30 synthetic table-top frames: frame 0 of scenes with seeds 1..30 (30 different layouts,
// camera heights and distances; default SceneParams). Each benchmark iteration processes one
// frame (cycling through the 30); counters give the SegComp correct-detection fraction
// (T = 0.8, truth planar surfaces >= 0.5% of the image) over the 30 frames, the median angle and
// distance errors of correctly detected planes, and the median per-frame thread CPU time.
//
// Public peers run on the same frames in the same run and are scored by the same code
// (plane_peers.h converts their output; their parameters are documented there):
//  - pcl_sac:    pcl::SACSegmentation sequential RANSAC on the organized cloud
//  (SHAPESENSE_BENCH_PCL)
//  - pcl_omps:   pcl::IntegralImageNormalEstimation + OrganizedMultiPlaneSegmentation (idem)
//  - cv_rgbdplane: cv::rgbd::RgbdNormals (FALS) + cv::rgbd::RgbdPlane
//  (SHAPESENSE_BENCH_OPENCV_RGBD)
// Every method starts from the millimetre depth image; its cloud / normals are part of its time.
// OpenCV runs single-threaded (cv::setNumThreads(1)) so that thread CPU time is all its work.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <functional>

#include <opencv2/core/utility.hpp>

#include "plane_peers.h"
#include "shapesense/core/planes/plane_ransac.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/plane_eval.h"

namespace shapesense {
namespace {

const std::vector<synthetic::RenderedFrame>& frames() {
  static const std::vector<synthetic::RenderedFrame> all = [] {
    std::vector<synthetic::RenderedFrame> v;
    for (std::uint64_t seed = 1; seed <= 30; ++seed) {
      synthetic::SceneParams sp;
      sp.seed = seed;
      v.push_back(synthetic::SyntheticScene(sp).render(0, 0));
    }
    return v;
  }();
  return all;
}

double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

void run(benchmark::State& state, const char* name,
         const std::function<PlaneDetection(const Frame&)>& detect) {
  cv::setNumThreads(1);
  const auto& fs = frames();
  // Accuracy and per-frame CPU time, once per run (outside the timed loop).
  eval::PlaneScore total;
  std::vector<double> ms;
  for (const auto& f : fs) {
    const double t0 = threadCpuMs();
    const PlaneDetection out = detect(f.frame);
    ms.push_back(threadCpuMs() - t0);
    total.add(eval::scorePlanes(out.labels, out.planes, f.truth));
  }
  std::sort(ms.begin(), ms.end());
  std::size_t i = 0;
  for (auto _ : state) {
    const PlaneDetection out = detect(fs[i++ % fs.size()].frame);
    benchmark::DoNotOptimize(out.planes.data());
  }
  const double median_ms = ms[ms.size() / 2];
  std::printf(
      "[%-12s] 30 frames: correct %.3f (%d/%d), median angle %.3f deg, median distance %.2f mm, "
      "median %.2f ms/frame (CPU)\n",
      name, total.correctFraction(), total.correct, total.truth_regions,
      eval::median(total.angle_deg), 1e3 * eval::median(total.dist_m), median_ms);
  state.counters["correct"] = total.correctFraction();
  state.counters["angle_deg"] = eval::median(total.angle_deg);
  state.counters["dist_mm"] = 1e3 * eval::median(total.dist_m);
  state.counters["median_cpu_ms"] = median_ms;
}

// The Hough detector with `params`, which keeps its buffers between frames, as in the daemon.
void runHough(benchmark::State& state, const char* name, const HoughPlaneParams& params) {
  HoughPlaneDetector det(params);
  run(state, name, [&](const Frame& f) { return det.detect(f.depth, f.intrinsics, f.rgb); });
}

void BM_NormalsHoughPlanes(benchmark::State& state) { runHough(state, "hough", {}); }
BENCHMARK(BM_NormalsHoughPlanes)->Unit(benchmark::kMillisecond);

// The Hough detector without the labelling's crease step (PlaneLabelingParams::crease_*): what
// the step costs, beside BM_NormalsHoughPlanes.
void BM_NormalsHoughPlanesNoCreaseStep(benchmark::State& state) {
  HoughPlaneParams params;
  params.labeling.crease_max_passes = 0;
  runHough(state, "hough-no-crease-step", params);
}
BENCHMARK(BM_NormalsHoughPlanesNoCreaseStep)->Unit(benchmark::kMillisecond);

// The Hough detector without the crease step's second part, the smaller face of a region on
// two faces given back (PlaneLabelingParams::minor_face_*), beside BM_NormalsHoughPlanes.
void BM_NormalsHoughPlanesNoMinorFaceStep(benchmark::State& state) {
  HoughPlaneParams params;
  params.labeling.minor_face_gain = 0.0;
  runHough(state, "hough-no-minor-face-step", params);
}
BENCHMARK(BM_NormalsHoughPlanesNoMinorFaceStep)->Unit(benchmark::kMillisecond);

// The Hough detector without the labelling's last step, the growth into pixels no sample
// reached (PlaneLabelingParams::grow_into_unreached_pixels): what it costs, beside
// BM_NormalsHoughPlanes.
void BM_NormalsHoughPlanesNoPixelGrowth(benchmark::State& state) {
  HoughPlaneParams params;
  params.labeling.grow_into_unreached_pixels = false;
  runHough(state, "hough-no-pixel-growth", params);
}
BENCHMARK(BM_NormalsHoughPlanesNoPixelGrowth)->Unit(benchmark::kMillisecond);

// The Hough detector without the split of planes and leftover components into two faces
// (HoughPlaneParams::two_face_gain): what it costs, beside BM_NormalsHoughPlanes.
void BM_NormalsHoughPlanesNoTwoFaceSplit(benchmark::State& state) {
  HoughPlaneParams params;
  params.two_face_gain = 0.0;
  runHough(state, "hough-no-two-face-split", params);
}
BENCHMARK(BM_NormalsHoughPlanesNoTwoFaceSplit)->Unit(benchmark::kMillisecond);

// The Hough detector without the check for facets of one curved surface
// (PlaneLabelingParams::curved_pair_*), beside BM_NormalsHoughPlanes.
void BM_NormalsHoughPlanesNoCurvedPairCheck(benchmark::State& state) {
  HoughPlaneParams params;
  params.labeling.curved_pair_rms_factor = 0.0;
  runHough(state, "hough-no-curved-pairs", params);
}
BENCHMARK(BM_NormalsHoughPlanesNoCurvedPairCheck)->Unit(benchmark::kMillisecond);

// The Hough detector with its accuracy steps switched off (leftover RANSAC, adaptive tolerance,
// coplanar region merging, the growth limit on unreliable normals, the crease step (both parts),
// the curved pair check, the pixel growth, the two-face split): what those steps cost and what they
// gain, beside BM_NormalsHoughPlanes.
void BM_NormalsHoughPlanesAccuracyStepsOff(benchmark::State& state) {
  HoughPlaneParams off;
  off.leftover_ransac_hypotheses = 0;
  off.labeling.adaptive_tolerance_factor = 0.0;
  off.labeling.merge_coplanar_regions = false;
  off.labeling.grow_max_unreliable_normal_deg = 180.0;
  off.labeling.crease_max_passes = 0;
  off.labeling.minor_face_gain = 0.0;
  off.labeling.curved_pair_rms_factor = 0.0;
  off.labeling.grow_into_unreached_pixels = false;
  off.two_face_gain = 0.0;
  runHough(state, "hough-basic", off);
}
BENCHMARK(BM_NormalsHoughPlanesAccuracyStepsOff)->Unit(benchmark::kMillisecond);

void BM_RansacPlanes(benchmark::State& state) {
  run(state, "ransac",
      [&](const Frame& f) { return detectPlanesRansac(f.depth, f.intrinsics, f.rgb); });
}
BENCHMARK(BM_RansacPlanes)->Unit(benchmark::kMillisecond);

#ifdef SHAPESENSE_BENCH_PCL
void BM_PclSacPlanes(benchmark::State& state) {
  run(state, "pcl_sac",
      [&](const Frame& f) { return peers::detectPlanesPclSac(f.depth, f.intrinsics); });
}
BENCHMARK(BM_PclSacPlanes)->Unit(benchmark::kMillisecond);

void BM_PclOmpsPlanes(benchmark::State& state) {
  peers::PclOmpsDetector det;
  run(state, "pcl_omps", [&](const Frame& f) { return det.detect(f.depth, f.intrinsics); });
}
BENCHMARK(BM_PclOmpsPlanes)->Unit(benchmark::kMillisecond);
#endif

#ifdef SHAPESENSE_BENCH_OPENCV_RGBD
void BM_OpenCvRgbdPlanes(benchmark::State& state) {
  peers::OpenCvRgbdPlaneDetector det(frames().front().frame.intrinsics);
  run(state, "cv_rgbdplane", [&](const Frame& f) { return det.detect(f.depth); });
}
BENCHMARK(BM_OpenCvRgbdPlanes)->Unit(benchmark::kMillisecond);
#endif

}  // namespace
}  // namespace shapesense
