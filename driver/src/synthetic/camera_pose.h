#pragma once
// Where the camera looks from and how it sways from frame to frame.

#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "random.h"

namespace shapesense::synthetic::detail {

/// OpenCV camera axes (x right, y down, z forward) looking from `eye` at `target`, world z up,
/// turned by `roll` about the viewing direction.
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double roll);

/// Slow periodic camera sway: per axis (tx, ty, tz in m, rx, ry, rz in rad, camera frame)
/// amplitude * sin(2 pi f t + phase).
struct Sway {
  std::array<double, 6> amplitude{};
  std::array<double, 6> frequency_hz{};
  std::array<double, 6> phase{};

  /// camera_at_base_from_camera at `seconds`, amplitudes scaled by `scale`.
  Eigen::Isometry3d at(double seconds, double scale) const;
};

/// A few cm and ~0.4-1 degree per axis, periods of 3-9 s.
Sway drawSway(Rng& rng);

}  // namespace shapesense::synthetic::detail
