#pragma once
// Per-region statistics of a segmentation (region image + the depth it was computed from).

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

struct SegmentStatistics {
  std::uint16_t id = 0;                                ///< region id in the region image
  int pixels = 0;                                      ///< pixels of the region that have depth
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< mean 3D point (metres, camera frame)
  /// Normal of the least-squares plane through the region's points (smallest eigenvector of their
  /// covariance; for a planar region this is the mean surface normal), unit, facing the camera
  /// (n . centroid < 0). Zero when the region has fewer than 3 points.
  Eigen::Vector3d mean_normal = Eigen::Vector3d::Zero();
  /// RMS orthogonal distance (metres) of the region's points to that plane.
  double plane_rms_m = 0.0;
  cv::Rect box;  ///< 2D bounding box of the region's pixels
};

/// Statistics of every non-zero region of `regions` (CV_16UC1), sorted by id. Pixels without
/// depth (depth_mm == 0) are skipped; regions with no pixel with depth are omitted.
std::vector<SegmentStatistics> computeSegmentStatistics(const cv::Mat& regions,
                                                        const cv::Mat& depth_mm,
                                                        const CameraIntrinsics& intrinsics);

}  // namespace shapesense
