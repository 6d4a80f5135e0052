#pragma once
// From plane hypotheses on a sample grid to the full-resolution output of a plane detector:
// region growing on the samples, connected regions, per-pixel assignment, per-region refit,
// colour and polygons. Shared by the Hough detector and the RANSAC baseline, so the two are
// compared on their plane finding alone.

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

/// A subsampled view of a depth image: sample (r, c) is pixel (offset + c*step, offset + r*step).
struct PlaneSampleGrid {
  int step = 1;
  int offset = 0;
  cv::Mat depth_mm;             ///< CV_16UC1 subsampled depth
  CameraIntrinsics intrinsics;  ///< of the subsampled image (a pinhole camera of its own)
  cv::Mat points;               ///< CV_32FC3 camera-frame points (m), NaN where invalid
  /// Optional (filled by detectors that estimate them): CV_32FC3 unit normals (NaN = none) and
  /// CV_8UC1 reliability (non-zero = the normal agrees with its neighbours: inside a smooth
  /// surface, not on a crease). Growth will not cross reliable normals of another orientation.
  cv::Mat normals;
  cv::Mat reliable;

  /// Fills depth_mm, intrinsics and points from a full-resolution depth image.
  void build(const cv::Mat& depth_full_mm, const CameraIntrinsics& full, int sample_step);
};

/// A plane hypothesis for labelling: n.X + d = 0.
struct PlaneHypothesis {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double d = 0.0;
};

/// Grows plane labels into unassigned valid samples that are depth-continuous with a labelled
/// 4-neighbour and within the tolerance of its plane (samples near edges and holes have no
/// normal, so detectors leave them unassigned). A sample with a reliable normal more than
/// params.grow_max_normal_deg off the plane is not taken: it belongs to a surface crossing the
/// plane (without this, every plane claims a band along each intersection line). `sample_labels` as
/// in labelPlanes.
void growSampleLabels(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                      const std::vector<PlaneHypothesis>& planes,
                      const PlaneLabelingParams& params);

/// Per plane, the RMS residual of the samples currently labelled with it, in sensor depth
/// steps at their range; negative for a plane with fewer than 6 samples (too few to tell).
std::vector<double> planeNoiseSteps(const PlaneSampleGrid& grid, const cv::Mat& sample_labels,
                                    const std::vector<PlaneHypothesis>& planes,
                                    const PlaneTolerance& tolerance);

/// Per plane, the coefficient c of its inlier tolerance max(tolerance.floor_m, c z^2) (see
/// PlaneLabelingParams::adaptive_tolerance_factor), from the samples currently labelled with it.
std::vector<float> planeToleranceCoefficients(const PlaneSampleGrid& grid,
                                              const cv::Mat& sample_labels,
                                              const std::vector<PlaneHypothesis>& planes,
                                              const PlaneLabelingParams& params);
/// The same from the planes' noise (planeNoiseSteps).
std::vector<float> planeToleranceCoefficients(const std::vector<double>& noise_steps,
                                              const PlaneLabelingParams& params);

/// Whether two neighbouring samples at ranges z1, z2 (m) are depth-continuous (one surface):
/// |z1 - z2| <= max(1% of the range per sample step, the tolerance at that range). Built once
/// per grid, because the tolerance constant costs a division and the loops test many pairs.
class SampleContinuity {
 public:
  SampleContinuity(const PlaneSampleGrid& grid, const PlaneLabelingParams& params)
      : range_factor_(0.01f * static_cast<float>(grid.step)),
        tol_k_(static_cast<float>(params.tolerance.noise_steps *
                                  params.tolerance.noise.depthStep(1.0))) {}
  bool operator()(float z1, float z2) const {
    const float z = std::min(z1, z2);
    return std::fabs(z1 - z2) <= std::max(range_factor_ * z, tol_k_ * z * z);
  }

 private:
  float range_factor_;  // 1% of the range per sample step
  float tol_k_;         // tolerance at 1 m (it grows with z^2)
};

/// Turns per-sample plane assignments into a PlaneDetection.
/// `sample_labels`: CV_32SC1 on the sample grid, -1 = none, k = index into `planes`; it is
/// modified (grown into unassigned samples that fit a neighbouring plane). Labels are 16-bit: of
/// more than 65535 connected regions (small sample steps on fragmented labels), those past the
/// first 65535 above the minimum size (in raster order of their first sample) stay unlabelled.
PlaneDetection labelPlanes(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                           const cv::Mat& bgr, const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                           const std::vector<PlaneHypothesis>& planes,
                           const PlaneLabelingParams& params);

}  // namespace shapesense
