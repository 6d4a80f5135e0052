#pragma once
// Unit conversions used across core/.

#include <algorithm>
#include <cmath>
#include <numbers>

namespace shapesense {

/// Degrees to radians, as degrees * (pi / 180).
constexpr double degToRad(double degrees) { return degrees * (std::numbers::pi / 180.0); }

/// Radians to degrees, as radians * (180 / pi).
constexpr double radToDeg(double radians) { return radians * (180.0 / std::numbers::pi); }

/// The angle (degrees) whose cosine is `cosine`, which is clamped to [-1, 1] first: the dot
/// product of two unit vectors can round to just beyond it.
inline double angleDegOfCosine(double cosine) {
  return radToDeg(std::acos(std::clamp(cosine, -1.0, 1.0)));
}

}  // namespace shapesense
