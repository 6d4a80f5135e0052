#include "two_views.h"

namespace shapesense::testing {

TwoViews twoViews(std::uint64_t seed, std::uint64_t later_index) {
  synthetic::SceneParams params;
  params.seed = seed;
  params.camera_motion = 1.5;
  const synthetic::SyntheticScene scene(params);
  TwoViews out{scene.render(0, 0), scene.render(later_index, 0), {}};
  out.truth = out.later.truth.world_from_camera.inverse() * out.teach.truth.world_from_camera;
  return out;
}

eval::PoseErrorDeg taughtObjectError(const Eigen::Isometry3f& estimated,
                                     const Eigen::Isometry3d& truth,
                                     const Eigen::Vector3f& model_centre,
                                     const synthetic::TruthObject& object) {
  return eval::poseError(estimated, truth, model_centre.cast<double>(), object.rotation,
                         eval::symmetryOfKind(object.kind), object.size,
                         eval::PoseTolerance{}.translation_m);
}

bool withinRecallTolerance(const eval::PoseErrorDeg& error) {
  const eval::PoseTolerance tolerance;
  return error.translation_m <= tolerance.translation_m &&
         error.rotation_deg <= tolerance.rotation_deg;
}

}  // namespace shapesense::testing
