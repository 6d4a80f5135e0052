#pragma once
// The one rule of core/ for "these two neighbouring depth readings lie on different surfaces":
// their difference exceeds the largest of a floor, a share of the range and a number of the
// sensor's depth quantisation steps at that range (which grow with z^2 on a Kinect v1).

#include <algorithm>
#include <cmath>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

struct DepthStepRule {
  double noise_steps = 3.0;     ///< sensor depth steps at the range. Default 3.
  double range_fraction = 0.0;  ///< share of the range (0.02 = 2 cm at 1 m). Default 0.
  double floor_m = 0.0;         ///< never below this (metres). Default 0.
  KinectNoiseModel noise{};     ///< the sensor. Default Kinect v1.

  /// Smallest difference (metres) that is a step at range z (metres).
  double threshold(double z) const {
    return std::max({floor_m, range_fraction * z, noise_steps * noise.depthStep(z)});
  }
  /// Whether readings z_a and z_b (metres) of neighbouring pixels are on different surfaces;
  /// the threshold is taken at the farther one, where the sensor is coarser.
  bool isStep(double z_a, double z_b) const {
    return std::abs(z_a - z_b) > threshold(std::max(z_a, z_b));
  }
};

}  // namespace shapesense
