#pragma once
// Replays a recording in the TUM RGB-D layout (see tum_recording.h) as a FrameSource.

#include <chrono>
#include <cstddef>
#include <deque>
#include <filesystem>

#include "shapesense/driver/frame_source.h"
#include "shapesense/driver/tum_recording.h"

namespace shapesense {

struct ReplayOptions {
  /// kRecorded sleeps so frames come at their recorded spacing; kAsFastAsPossible does not.
  Pacing pacing = Pacing::kRecorded;
  /// Start again at the end; each pass shifts timestamps by the recording's length (last minus
  /// first stamp plus one typical frame period) so time keeps increasing. The replay ends, with
  /// one SourceError, where the stamps would pass the 64-bit nanosecond range (year 2262).
  bool loop = false;
  /// An RGB image is paired with a depth image when their stamps differ by at most this.
  std::chrono::milliseconds max_rgb_offset{20};
};

class ReplaySource : public FrameSource {
 public:
  /// Reads the index files; throws std::runtime_error when the recording cannot be used at all
  /// (missing directory or depth.txt, malformed camera.json, no depth entry).
  ReplaySource(std::filesystem::path dir, ReplayOptions options = {});

  std::string describe() const override;

  /// Delivers the next depth frame. A missing, unreadable, truncated or wrong-sized file is
  /// reported as SourceError naming its path, and the replay moves on to the next frame; so is a
  /// file that is not regular, is larger than a PNG of the camera's size can be, leads out of
  /// the recording through a symlink, or whose PNG header disagrees with camera.json (checked
  /// before decoding).
  SourceEvent next(std::stop_token stop) override;

  /// Number of depth frames in one pass.
  std::size_t frameCount() const { return index_.depth.size(); }

 private:
  SourceEvent loadFrame(const TumIndexEntry& entry, TimestampNs timestamp_ns);
  const TumIndexEntry* nearestRgb(TimestampNs t) const;

  std::filesystem::path dir_;
  ReplayOptions options_;
  TumIndex index_;
  std::deque<std::string> pending_problems_;
  TimestampNs pass_length_ns_ = 0;
  std::size_t position_ = 0;  // next depth entry
  std::uint64_t pass_ = 0;    // completed passes (loop)
  std::uint64_t sequence_ = 0;
  bool started_ = false;
  std::chrono::steady_clock::time_point wall_start_;
  TimestampNs recording_start_ns_ = 0;
};

}  // namespace shapesense
