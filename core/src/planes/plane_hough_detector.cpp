// HoughPlaneDetector: the outline of detect(); each step is a function of its own (see
// hough_detector_steps.h for the list and the files that hold them).
#include <algorithm>
#include <memory>

#include "planes/hough_detector_steps.h"
#include "shapesense/core/planes/plane_labeling.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

NormalParams HoughPlaneParams::defaultSampleNormalParams(int step) {
  step = std::max(1, step);
  NormalParams p;
  p.method = NormalMethod::kAverage3dGradient;
  // Windows in grid cells: half-size 8 px of the full image at 1 m, growing with range.
  p.smoothing_radius_px = 8.0 / step;
  p.depth_dependent_smoothing = true;
  p.min_radius_px = 1;
  p.max_radius_px = std::max(1, 24 / step);
  // Neighbouring samples are `step` pixels apart, so the per-neighbour depth change that counts
  // as a step scales with it (1% of range per pixel: 4 cm at 1 m for step 4), and so do gaps.
  p.max_depth_change_factor = 0.01 * step;
  p.max_gap_px = std::max(1, 8 / step);
  // A noisy sensor at range: with the fixed rule alone, a wall 4 m away read with 0.15 px of
  // noise kept a quarter of its samples' normals, and no plane (3-6 tried on the validation
  // split, docs/benchmarks.md).
  p.depth_change_noise_sigmas = 4.0;
  return p;
}

HoughPlaneDetector::HoughPlaneDetector(HoughPlaneParams params)
    : params_(params), impl_(std::make_unique<Impl>(params_)) {}
HoughPlaneDetector::~HoughPlaneDetector() = default;
HoughPlaneDetector::HoughPlaneDetector(HoughPlaneDetector&&) noexcept = default;
HoughPlaneDetector& HoughPlaneDetector::operator=(HoughPlaneDetector&&) noexcept = default;

const HoughAccumulator& HoughPlaneDetector::lastSmoothedSpace() const { return impl_->smooth; }

PlaneDetection HoughPlaneDetector::detect(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                          const cv::Mat& bgr) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  Impl& s = *impl_;
  const HoughPlaneParams& P = params_;
  if (!s.sampleFrame(depth_mm, K, P))  // no sample, no plane
    return labelPlanes(depth_mm, K, bgr, s.grid, s.sample_labels, {}, P.labeling);
  s.markReliableSamples(P);
  std::vector<PlaneHypothesis> planes = s.findPlanesByVoting(P);
  mergeNearDuplicatePlanes(s.grid, s.sample_labels, planes, P);
  splitTwoFacedPlanes(s.grid, s.sample_labels, planes, P);
  if (P.fit_leftover_components) {
    s.fitLeftoverComponents(P, planes);
    mergeNearDuplicatePlanes(s.grid, s.sample_labels, planes, P);
  }
  return labelPlanes(depth_mm, K, bgr, s.grid, s.sample_labels, planes, P.labeling);
}

}  // namespace shapesense
