#include "synthetic_frames.h"

#include <cmath>

namespace shapesense::testing {

std::vector<synthetic::RenderedFrame> renderSyntheticSequence(std::uint64_t seed, int count,
                                                              TimestampNs start_ns) {
  synthetic::SceneParams params;
  params.seed = seed;
  const synthetic::SyntheticScene scene(params);
  std::vector<synthetic::RenderedFrame> frames;
  frames.reserve(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    const auto offset = static_cast<TimestampNs>(std::llround(i * 1e9 / 30.0));
    frames.push_back(scene.render(static_cast<std::uint64_t>(i), start_ns + offset));
  }
  return frames;
}

std::vector<Frame> syntheticFrames(std::uint64_t seed, int count, TimestampNs start_ns) {
  std::vector<Frame> frames;
  for (auto& rendered : renderSyntheticSequence(seed, count, start_ns))
    frames.push_back(std::move(rendered.frame));
  return frames;
}

}  // namespace shapesense::testing
