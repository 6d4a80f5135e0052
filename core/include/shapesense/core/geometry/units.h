#pragma once
// Unit conversions used across core/.

#include <numbers>

namespace shapesense {

constexpr double kDegToRad = std::numbers::pi / 180.0;

constexpr double degToRad(double degrees) { return degrees * kDegToRad; }

}  // namespace shapesense
