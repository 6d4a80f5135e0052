#pragma once
// The estimators' view of the input: a z plane, and the pixel rays (depth input) or the point
// image (point input). Internal to core/src/normals/.

#include <opencv2/core.hpp>

#include "normals/normal_workspace.h"
#include "shapesense/core/geometry/camera.h"

namespace shapesense::detail {

/// Reads a CV_16UC1 depth image (mm) or a CV_32FC3 point image (m) into `input`. Depth input
/// keeps only the z plane and the rays (the points are z times the rays); the points are built
/// on demand by buildPoints().
void loadInput(const cv::Mat& depth_or_points, const CameraIntrinsics& intrinsics,
               NormalInput& input);

/// Depth input: builds input.points (once per frame) from the z plane and the rays.
void buildPoints(NormalInput& input);

}  // namespace shapesense::detail
