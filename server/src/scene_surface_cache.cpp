#include "shapesense/server/scene_surface_cache.h"

namespace shapesense {

std::shared_ptr<const SceneSurface> SceneSurfaceCache::get(const Frame& frame,
                                                           const ObjectModelParams& params,
                                                           bool& reused) {
  std::promise<std::shared_ptr<const SceneSurface>> promise;
  std::shared_future<std::shared_ptr<const SceneSurface>> surface;
  {
    std::lock_guard lock(mutex_);
    reused = has_frame_ && sequence_ == frame.sequence;
    if (!reused) {
      has_frame_ = true;
      sequence_ = frame.sequence;
      surface_ = promise.get_future().share();
    }
    surface = surface_;
  }
  if (!reused) {
    // Built outside the lock: a call on another frame need not wait for this one.
    try {
      promise.set_value(
          std::make_shared<const SceneSurface>(frame.depth, frame.intrinsics, params));
    } catch (...) {
      promise.set_exception(std::current_exception());
      std::lock_guard lock(mutex_);
      if (has_frame_ && sequence_ == frame.sequence) has_frame_ = false;  // the next call retries
    }
  }
  return surface.get();
}

}  // namespace shapesense
