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

}  // namespace shapesense::testing
