#pragma once
// Bounded waits on a frame source, so a test of a live or replayed source fails instead of
// hanging when the source never delivers.

#include <chrono>
#include <stop_token>

#include "shapesense/driver/frame_source.h"

namespace shapesense::testing {

/// The source's next event, or whatever next() returns once asked to stop after `limit`.
SourceEvent nextWithin(FrameSource& source, std::chrono::milliseconds limit);

/// Blocks until `stop` is requested, as a live sensor with nothing to send does in next().
void waitUntilStopped(std::stop_token stop);

}  // namespace shapesense::testing
