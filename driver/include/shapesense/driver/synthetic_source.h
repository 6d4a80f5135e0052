#pragma once
// A FrameSource that renders a SyntheticScene: the stand-in sensor for tests, demos and CI.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>

#include "shapesense/driver/frame_source.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::synthetic {

struct SyntheticSourceOptions {
  /// The scene. Its frame_rate_hz is replaced by `fps` so the camera sway runs in real time.
  SceneParams scene;
  double fps = 30.0;                  ///< frame rate of the stamps (and of pacing). Default 30.
  Pacing pacing = Pacing::kRecorded;  ///< kRecorded sleeps to `fps`; kAsFastAsPossible does not.
  std::uint64_t max_frames = 0;       ///< EndOfStream after this many frames; 0 = endless.
  /// Stamp of frame 0; frame i is stamped start_ns + round(i * 1e9 / fps).
  /// 0 = the host CLOCK_REALTIME at construction.
  TimestampNs start_ns = 0;
};

/// Frame i is SyntheticScene::render(i, start_ns + i / fps) with sequence i, so the truth of
/// any delivered frame can be recomputed with scene().render(frame.sequence, ...).truth or
/// taken from lastTruth().
class SyntheticSource final : public FrameSource {
 public:
  /// Throws std::invalid_argument for fps <= 0 or bad scene params.
  explicit SyntheticSource(SyntheticSourceOptions options);

  /// "synthetic(seed=<seed>)".
  std::string describe() const override;

  /// Renders the next frame. When paced, frame i is not returned before i / fps seconds after
  /// the first call; a stop request during that wait returns EndOfStream at once.
  SourceEvent next(std::stop_token stop) override;

  const SyntheticScene& scene() const { return scene_; }
  const SyntheticSourceOptions& options() const { return options_; }

  /// Ground truth of the frame last returned by next(); nullopt before the first frame.
  /// Same threading rule as next().
  const std::optional<TruthFrame>& lastTruth() const { return last_truth_; }

 private:
  TimestampNs stampOf(std::uint64_t index) const;

  SyntheticSourceOptions options_;
  SyntheticScene scene_;
  TimestampNs start_ns_;
  std::uint64_t next_index_ = 0;
  std::optional<std::chrono::steady_clock::time_point> first_call_;
  std::optional<TruthFrame> last_truth_;
  std::mutex wait_mutex_;  ///< only for the stop-aware sleep
  std::condition_variable_any wait_cv_;
};

}  // namespace shapesense::synthetic
