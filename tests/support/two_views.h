#pragma once
// Two views of one synthetic scene for the recognition tests: frame 0, where objects are
// taught, and a later frame of the same scene whose camera moved (sway 1.5), with the truth
// motion between their camera frames.

#include <cstdint>

#include <Eigen/Geometry>

#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/recognition_eval.h"

namespace shapesense::testing {

struct TwoViews {
  synthetic::RenderedFrame teach;
  synthetic::RenderedFrame later;
  Eigen::Isometry3d truth;  ///< teaching camera frame -> later camera frame
};

TwoViews twoViews(std::uint64_t seed, std::uint64_t later_index);

/// The error of `estimated` (camera from model) for `object`, taught in the teaching view with
/// its model's centre at `model_centre`, against `truth` (teaching camera -> searched camera):
/// at that centre, up to the object's symmetry.
eval::PoseErrorDeg taughtObjectError(const Eigen::Isometry3f& estimated,
                                     const Eigen::Isometry3d& truth,
                                     const Eigen::Vector3f& model_centre,
                                     const synthetic::TruthObject& object);

/// Within issue 22's tolerance for recall (eval::PoseTolerance: 1 cm and 5 deg).
bool withinRecallTolerance(const eval::PoseErrorDeg& error);

}  // namespace shapesense::testing
