#pragma once
// The full-resolution pixel labelling step of labelPlanes: every pixel takes the closest candidate
// plane of its sample neighbourhood within the tolerance, region moments and colour are summed on
// the way, and the labels can be renumbered afterwards run by run.

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense::labeling {

/// A region's moments and colour are summed on every kMomentStride-th pixel of every
/// kMomentStride-th row (from pixel (0, 0)): see labelPixels.
inline constexpr int kMomentStride = 2;

/// A plane n.X + d = 0 in the pinhole form: the pixel (u, v) at depth z lies
/// z (a u + (b v + c)) + d from it (signed, positive towards the camera; d in z's unit).
struct PinholePlane {
  float a = 0.0f, b = 0.0f, c = 0.0f, d = 0.0f;
  float residual(int u, int v, float z) const {
    return z * (a * static_cast<float>(u) + (b * static_cast<float>(v) + c)) + d;
  }
};

/// The plane with unit `normal` and offset `d` (in the unit the residuals are to be in) as seen
/// through the pinhole camera K.
PinholePlane pinholePlane(const Eigen::Vector3d& normal, double d, const CameraIntrinsics& K);

/// One region of samples (one plane, connected) and what its pixels add up to.
struct RegionAccumulator {
  int plane = -1;       // index into the hypotheses
  bool curved = false;  // lies on a curved surface: not reported (labeling::curvedRegions)
  int samples = 0;
  cv::Rect sample_box;  // on the sample grid
  // Full-resolution accumulation: raw moments (camera frame, in double: the covariance of a
  // region metres away keeps ~8 significant digits), added run by run.
  PlaneMoments moments{Eigen::Vector3d::Zero()};
  std::size_t count = 0;
  int u0 = std::numeric_limits<int>::max(), v0 = std::numeric_limits<int>::max(), u1 = -1, v1 = -1;
  std::array<std::uint64_t, 3> colour{};
};

// The regions a sample's pixels may take: the distinct regions of its 3x3 sample
// neighbourhood, its own first, -1 terminated (at most 4).
using CandidateList = std::array<int, 4>;

// A horizontal run of pixels of one image row whose samples share one candidate list.
struct PixelRun {
  int u0 = 0, u1 = 0;  // [u0, u1)
  CandidateList list{};
};

// The candidate runs of every sample row, kept for the renumbering at the end.
struct LabelRuns {
  std::vector<PixelRun> runs;
  std::vector<int> row_begin;   // runs of sample row r: [row_begin[r], row_begin[r + 1])
  std::vector<int> row_sample;  // sample row of each image row
};

/// Every full-resolution pixel takes the closest candidate plane of its sample within the
/// tolerance (labels: region index + 1, CV_16UC1); moments, pixel bounds and colour of the regions
/// are accumulated on the way. region_of: region of each sample (-1: none); region_tol: tolerance
/// coefficient of each region. Returns the candidate runs (for renumberLabels).
LabelRuns labelPixels(const cv::Mat& depth_mm, const CameraIntrinsics& K, const cv::Mat& bgr,
                      const PlaneSampleGrid& grid, const int* region_of,
                      const std::vector<PlaneHypothesis>& planes,
                      const std::vector<float>& region_tol, float tol_floor,
                      std::vector<RegionAccumulator>& regions, cv::Mat& labels);

/// Applies `lut` (new label of each label; lut[l] <= l) to the labelled pixels, run by run.
void renumberLabels(cv::Mat& labels, const LabelRuns& lr, const std::vector<std::uint16_t>& lut);

}  // namespace shapesense::labeling
