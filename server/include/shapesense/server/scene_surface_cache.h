#pragma once
// The SceneSurface (core/recognition/object_matching.h) of the last frame FindObjects searched:
// it takes tens of milliseconds to build, and clients tend to ask several questions of one
// frame (one call per object, or a call and its retry). Callers that want the same frame at
// once wait for the one build instead of each building it.

#include <cstdint>
#include <future>
#include <memory>
#include <mutex>

#include "shapesense/core/geometry/frame.h"
#include "shapesense/core/recognition/object_matching.h"

namespace shapesense {

class SceneSurfaceCache {
 public:
  /// The surface of `frame` described with `params`: the kept one when it is of this frame's
  /// sequence, else built now and kept (replacing the previous frame's). `reused` says which.
  std::shared_ptr<const SceneSurface> get(const Frame& frame, const ObjectModelParams& params,
                                          bool& reused);

 private:
  std::mutex mutex_;
  bool has_frame_ = false;
  std::uint64_t sequence_ = 0;
  std::shared_future<std::shared_ptr<const SceneSurface>> surface_;
};

}  // namespace shapesense
