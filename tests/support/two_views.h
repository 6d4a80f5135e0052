#pragma once
// Two views of one synthetic scene for the recognition tests: frame 0, where objects are
// taught, and a later frame of the same scene whose camera moved (sway 1.5), with the truth
// motion between their camera frames.

#include <cstdint>

#include <Eigen/Geometry>

#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::testing {

struct TwoViews {
  synthetic::RenderedFrame teach;
  synthetic::RenderedFrame later;
  Eigen::Isometry3d truth;  ///< teaching camera frame -> later camera frame
};

TwoViews twoViews(std::uint64_t seed, std::uint64_t later_index);

}  // namespace shapesense::testing
