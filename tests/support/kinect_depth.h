#pragma once
// The Kinect v1's depth reading of a true range, for tests that ray-cast scenes of their own:
// Gaussian disparity noise, quantised to the sensor's 1/8 px disparity step.

#include <cstdint>
#include <random>

namespace shapesense::testing {

/// The reading in mm for a surface `range_m` ahead along the optical axis (z, m), with
/// disparity noise of `disparity_sigma_px` drawn from `rng`.
std::uint16_t kinectDepthMm(double range_m, std::mt19937& rng, double disparity_sigma_px = 0.07);

}  // namespace shapesense::testing
