#pragma once
// Short synthetic sequences for tests that need realistic Kinect-like frames (fakenect dumps,
// recordings): frame i of one scene, captured 1/30 s apart.

#include <cstdint>
#include <vector>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::testing {

/// A capture time far from zero so unwrapping and epoch conversions are exercised.
inline constexpr TimestampNs kSyntheticStartNs = 1'700'000'000'000'000'000;

/// Frames 0..count-1 of the default scene with `seed`, stamped start_ns + i/30 s (rounded to
/// the nanosecond), with their ground truth.
std::vector<synthetic::RenderedFrame> renderSyntheticSequence(
    std::uint64_t seed, int count, TimestampNs start_ns = kSyntheticStartNs);

/// The frames alone of renderSyntheticSequence.
std::vector<Frame> syntheticFrames(std::uint64_t seed, int count,
                                   TimestampNs start_ns = kSyntheticStartNs);

}  // namespace shapesense::testing
