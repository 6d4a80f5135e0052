#pragma once
// Depth frames with Kinect v1 quantisation for the normals tests.

#include <cmath>
#include <cstdint>
#include <random>

#include "shapesense/core/normals/normals.h"

namespace shapesense::normaltest {

/// Depth (metres) -> Kinect v1 millimetres: disparity 43.5/z px (+ Gaussian noise of
/// `noise_steps` quantisation steps), rounded to 1/8 px.
inline std::uint16_t kinectQuantise(double z, double noise_steps, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  double disp = 43.5 / z * 8.0 + noise_steps * n(rng);
  disp = std::round(disp);
  if (disp <= 0) return 0;
  return static_cast<std::uint16_t>(std::lround(43.5 / (disp / 8.0) * 1000.0));
}

inline const char* name(NormalMethod m) {
  switch (m) {
    case NormalMethod::kCovariance:
      return "covariance";
    case NormalMethod::kAverage3dGradient:
      return "average_3d_gradient";
    case NormalMethod::kAverageDepthChange:
      return "average_depth_change";
  }
  return "?";
}

}  // namespace shapesense::normaltest
