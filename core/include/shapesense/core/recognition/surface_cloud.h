#pragma once
// Points with unit surface normals: what the shape descriptors (shape_features.h) and the
// object matching (object_matching.h) read, whether the surface came from a depth frame or from
// a point cloud (a PLY file, a model).
//
// Both inputs are thinned to one point per voxel (the mean of the points in it), so that the
// density no longer depends on the range or the scanner: a descriptor counts the surface, not
// the pixels. A depth frame's normals come from the organised normal estimator (normals.h),
// which knows the image's neighbours and its depth steps; an unorganised cloud without normals
// gets them from the points around each point (the smallest principal axis).

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/normals/normals.h"

namespace shapesense {

struct SurfaceCloud {
  std::vector<Eigen::Vector3f> points;   ///< metres
  std::vector<Eigen::Vector3f> normals;  ///< unit, facing the viewpoint; same size as points

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
};

struct SurfaceCloudParams {
  /// Side of the voxels the cloud is thinned to (m). Default 5 mm: about two Kinect pixels at
  /// 1.5 m, so near surfaces are thinned and far ones keep every reading.
  float voxel_m = 0.005f;
  /// Depth frames: every `pixel_stride`-th pixel in each direction is read. Default 1.
  int pixel_stride = 1;
  /// Readings beyond this range are left out (m). Default 4.5, the Kinect's far limit.
  float max_range_m = 4.5f;
  /// Unorganised clouds without normals: the radius whose points give each normal (m).
  /// Default 1.5 cm.
  float normal_radius_m = 0.015f;
  /// ...and the fewest points within it; a point with fewer is dropped. Default 6.
  int min_normal_neighbours = 6;
  /// The organised estimator's parameters for depth frames.
  NormalParams normals{};
};

/// The surface of `depth_mm` (CV_16UC1 millimetres) in the camera frame, restricted to the
/// pixels where `mask` (CV_8UC1, optional: empty = every pixel) is non-zero. Pixels without a
/// reading or without a normal (at depth steps) are left out. Normals face the camera.
SurfaceCloud surfaceCloudFromDepth(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                   const cv::Mat& mask = {}, const SurfaceCloudParams& params = {});

/// The surface of an unorganised cloud. `normals` may be empty (then estimated) or hold one
/// normal per point; either way they are turned to face `viewpoint` (the scanner's position in
/// the cloud's frame; the origin for a camera-frame cloud).
SurfaceCloud surfaceCloudFromPoints(const std::vector<Eigen::Vector3f>& points,
                                    const std::vector<Eigen::Vector3f>& normals = {},
                                    const Eigen::Vector3f& viewpoint = Eigen::Vector3f::Zero(),
                                    const SurfaceCloudParams& params = {});

}  // namespace shapesense
