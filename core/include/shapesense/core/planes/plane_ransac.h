#pragma once
// Sequential multi-plane RANSAC: the baseline the Hough detector is compared against.
// On the same sample grid and with the same labelling (plane_labeling.h) as the Hough detector,
// so a comparison measures plane finding alone. Per plane: `iterations` hypotheses from three
// samples (the second and third drawn near the first, which makes small planes findable at
// all), scored by the number of remaining samples within the range-dependent tolerance; the
// best is refitted by least squares on its inliers, which are then removed. Stops when the
// best plane has fewer than min_plane_samples inliers or after max_planes.

#include <cstdint>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

struct RansacPlaneParams {
  PlaneLabelingParams labeling{};  ///< sampling, tolerance and output, as for the Hough detector
  int iterations = 200;            ///< hypotheses per plane. Default 200.
  int max_planes = 30;             ///< Default 30.
  int min_plane_samples = 18;      ///< smallest accepted plane (samples). Default 18.
  /// Half-size (samples) of the window the 2nd and 3rd points are drawn from; 0 = anywhere.
  /// Default 10 (40 px at step 4).
  int neighbourhood_samples = 10;
  std::uint64_t seed = 1;  ///< random generator seed (results are deterministic). Default 1.
};

PlaneDetection detectPlanesRansac(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                  const cv::Mat& bgr = {}, const RansacPlaneParams& params = {});

}  // namespace shapesense
