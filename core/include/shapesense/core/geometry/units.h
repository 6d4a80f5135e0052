#pragma once
// Unit conversions used across core/.

#include <numbers>

namespace shapesense {

/// Degrees to radians, as degrees * (pi / 180).
constexpr double degToRad(double degrees) { return degrees * (std::numbers::pi / 180.0); }

}  // namespace shapesense
