#pragma once
// Boundary polygons of planar regions, for display: the outer contour of a region mask
// (a concave hull of the inliers), simplified, cast onto the plane, and ear-clip triangulated.

#include <array>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

/// Triangulates a simple polygon (either orientation) by ear clipping. Returns n-2 triangles
/// of indices into `poly`, or a fan when the polygon is not simple enough to clip.
std::vector<std::array<int, 3>> triangulatePolygon(const std::vector<cv::Point2f>& poly);

/// Polygon of the region `mask` (CV_8UC1, non-zero = region) whose cell (r, c) is pixel
/// (offset + scale * (c + origin.x), offset + scale * (r + origin.y)) of a camera with
/// `intrinsics`; vertices are intersections of the pixel rays with plane n.X + d = 0.
/// `epsilon_cells`: Douglas-Peucker tolerance in mask cells. Empty when the region is degenerate.
void regionPolygon(const cv::Mat& mask, cv::Point origin, double scale, double offset,
                   const Eigen::Vector3d& normal, double d, const CameraIntrinsics& intrinsics,
                   double epsilon_cells, std::vector<Eigen::Vector3d>& polygon,
                   std::vector<std::array<int, 3>>& triangles);

}  // namespace shapesense
