#include "kinect_depth.h"

#include <cmath>

namespace shapesense::testing {

std::uint16_t kinectDepthMm(double range_m, std::mt19937& rng, double disparity_sigma_px) {
  constexpr double kFocalBaseline = 43.5;  // focal length (px) times baseline (m), over 8
  constexpr double kDisparityStep = 0.125;
  std::normal_distribution<double> noise(0.0, disparity_sigma_px);
  double disparity = kFocalBaseline / range_m + noise(rng);
  disparity = std::round(disparity / kDisparityStep) * kDisparityStep;
  return static_cast<std::uint16_t>(std::lround(1e3 * kFocalBaseline / disparity));
}

}  // namespace shapesense::testing
