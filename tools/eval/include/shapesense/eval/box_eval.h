#pragma once
// Scoring of 3D boxes against the points an object shows: how many of them a box holds, and
// how much bigger the box is than those points need. Used for EstimateBox's modes on synthetic
// truth objects and on the labelled real OSD objects, with the object's own image bounds as the
// ROI an operator would draw.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::eval {

/// The 3D points of the pixels where `is_object(label)` holds and the depth has a reading.
template <typename Predicate>
std::vector<Eigen::Vector3d> labelledPoints(const cv::Mat& labels, const cv::Mat& depth_mm,
                                            const CameraIntrinsics& intrinsics,
                                            Predicate is_object) {
  std::vector<Eigen::Vector3d> points;
  for (int v = 0; v < labels.rows; ++v) {
    const auto* label = labels.ptr<std::uint16_t>(v);
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (depth[u] != 0 && is_object(label[u]))
        points.push_back(intrinsics.backproject(u, v, 1e-3 * depth[u]));
  }
  return points;
}

/// Volume (m^3) of the camera-axis-aligned box around `points` (the box "of those points").
double pointsBoxVolume(const std::vector<Eigen::Vector3d>& points);

/// Boxes of one mode over many objects.
struct BoxModeScore {
  int objects = 0;
  int failed = 0;                    ///< no box (an error status)
  std::vector<double> coverage;      ///< per boxed object: share of its points inside the box
  std::vector<double> volume_ratio;  ///< per boxed object: box volume / pointsBoxVolume
  /// Scores one object's box (or its absence) against the object's visible points.
  void add(const BoxCorners* box, const std::vector<Eigen::Vector3d>& points);
  void add(const BoxModeScore& other);
  /// Mean share of the objects' points inside their boxes, a failed box counting 0.
  double meanCoverage() const;
};

/// Truth objects an operator would box: not room structure, the table or a shelf unit, with at
/// least `min_pixels` labelled pixels and an image box that does not touch the image border.
std::vector<const synthetic::TruthObject*> boxableObjects(const synthetic::TruthFrame& truth,
                                                          int image_cols, int image_rows,
                                                          std::size_t min_pixels);

}  // namespace shapesense::eval
