#pragma once
// The device interface: everything that delivers frames (a live sensor, a recording, the
// synthetic scene) implements FrameSource, and nothing above driver/ knows which one it has.

#include <cstdint>
#include <memory>
#include <stop_token>
#include <string>
#include <variant>

#include "shapesense/core/geometry/frame.h"

namespace shapesense {

/// A frame could not be delivered, but the source can go on (a corrupt file in a recording,
/// a dropped USB transfer). The message names what failed, e.g. the file's path.
struct SourceError {
  std::string message;
};

/// The source has no more frames (end of a recording without --loop).
struct EndOfStream {};

/// One result of FrameSource::next().
using SourceEvent = std::variant<Frame, SourceError, EndOfStream>;

/// Whether a recorded source paces frames at their recorded rate or hands them out as fast as
/// they are asked for.
enum class Pacing { kRecorded, kAsFastAsPossible };

/// The sensor state behind a source, for status displays. Recordings and the synthetic scene
/// keep the default: not live, always connected.
struct SourceHealth {
  bool live = false;                 ///< a sensor that can be lost and reopened
  bool connected = true;             ///< open and delivering
  std::uint64_t reconnects = 0;      ///< times reopened after a loss
  std::uint64_t disconnects = 0;     ///< times lost after being open (unplugged, failed, silent)
  std::uint64_t dropped_frames = 0;  ///< dropped because next() was not called fast enough
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  /// Short description for status and logs, e.g. "synthetic(seed=1)" or "tum:/data/desk".
  virtual std::string describe() const = 0;

  /// Blocks until the next frame, an error, or the end. Pacing sleeps return early (with
  /// EndOfStream) once `stop` is requested. Frames carry increasing sequence numbers.
  /// Called from one thread at a time.
  virtual SourceEvent next(std::stop_token stop) = 0;

  /// The sensor state; may be called from any thread while another calls next().
  virtual SourceHealth health() const { return {}; }
};

}  // namespace shapesense
