#pragma once
// Depth frames of hand-built scenes for tests: flat rectangular faces before a wall, ray-cast
// through the Kinect v1's intrinsics, read with the sensor's disparity noise and quantisation.

#include <cstdint>
#include <optional>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense::testing {

/// The reading in mm for a surface `range_m` ahead along the optical axis (z, m), with
/// disparity noise of `disparity_sigma_px` drawn from `rng`, quantised to 1/8 px.
std::uint16_t kinectDepthMm(double range_m, std::mt19937& rng, double disparity_sigma_px = 0.07);

/// One rectangular face: the points E + s t + y (0, 1, 0) with s in [0, width] and
/// |y| <= half_height.
struct Face {
  Eigen::Vector3d normal;  ///< towards the camera
  Eigen::Vector3d edge;    ///< E
  Eigen::Vector3d along;   ///< t, unit, orthogonal to the normal and to y
  double width = 0.0;
  double half_height = 0.3;

  PlaneHypothesis plane() const { return {normal, -normal.dot(edge)}; }
  /// Range (z) of the face along the pixel's ray, if the ray meets it.
  std::optional<double> rangeAt(const Eigen::Vector3d& ray) const;
};

/// A frame of `faces` before a wall facing the camera `wall_m` ahead, read with disparity noise
/// of `disparity_sigma_px`.
struct FaceFrame {
  cv::Mat depth;  ///< CV_16UC1 mm, as the Kinect v1 reads it
  cv::Mat face;   ///< CV_8UC1: i + 1 where faces[i] is seen, 0 on the wall
};
FaceFrame renderFaces(const std::vector<Face>& faces, double wall_m, unsigned seed,
                      double disparity_sigma_px = 0.07);

}  // namespace shapesense::testing
