#pragma once
// Bounded waits on a frame source, so a test of a live or replayed source fails instead of
// hanging when the source never delivers.

#include <chrono>

#include "shapesense/driver/frame_source.h"

namespace shapesense::testing {

/// The source's next event, or whatever next() returns once asked to stop after `limit`.
SourceEvent nextWithin(FrameSource& source, std::chrono::milliseconds limit);

}  // namespace shapesense::testing
