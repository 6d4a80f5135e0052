#pragma once
// The daemon's frame path: a capture thread pulls frames from the source into the cache, and a
// detector thread runs the detector chain on the newest frame, publishes the results to the
// cache and to Watch subscribers. When the detectors fall behind, frames stay cached but are not
// processed: the detector thread always takes the newest waiting frame and the ones it passed
// over are counted as skipped, so nothing queues without bound.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/frame_source.h"
#include "shapesense/server/frame_cache.h"
#include "shapesense/server/frame_tap.h"
#include "shapesense/server/latency_tracker.h"
#include "shapesense/server/summary_hub.h"

namespace shapesense {

/// kReconnecting: a live sensor is not connected (not found yet, or lost and being reopened);
/// the capture thread keeps waiting for it and the cache keeps serving.
enum class SourceState { kStreaming, kEnded, kFailed, kStopped, kReconnecting };

struct PipelineStatus {
  std::string source;
  SourceState state = SourceState::kStreaming;
  std::string last_error;  ///< the source's last reported problem
  std::uint64_t frames_received = 0;
  std::uint64_t frames_processed = 0;
  std::uint64_t frames_skipped = 0;
  std::uint64_t source_errors = 0;
  /// Frames the cache refused: stamped at or before the newest cached frame (a clock that
  /// jumped back or repeated). Not in frames_received.
  std::uint64_t frames_out_of_order = 0;
  std::vector<LatencySummary> stages;  ///< per stage, plus "total" for the whole chain
  std::vector<std::string> detectors;
  SourceHealth health;  ///< the source's sensor state (FrameSource::health())
};

/// When each thread last moved, for the watchdog (pipeline_health.h).
struct PipelineProgress {
  std::string source;
  SourceState state = SourceState::kStreaming;
  /// The last frame, error or end from the source; the start while there was none.
  std::chrono::steady_clock::time_point last_source_event;
  /// Set while the detector thread runs the chain on a frame: when it began.
  std::optional<std::chrono::steady_clock::time_point> detecting_since;
};

struct PipelineOptions {
  /// Nice value of the capture and detector threads (named ss-capture and ss-detect). Below the
  /// process's own it needs root, CAP_SYS_NICE or an RLIMIT_NICE that allows it; when the
  /// system refuses, the threads keep the process's priority and the daemon says so once. 0 =
  /// leave them at the process's priority.
  int thread_nice = 0;
};

class Pipeline {
 public:
  Pipeline(std::unique_ptr<FrameSource> source, DetectorChain chain, FrameCache& cache,
           SummaryHub& hub, FrameTap* tap = nullptr, PipelineOptions options = {});
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  void start();
  /// Stops both threads and waits for them; the cache keeps what it holds.
  void stop();

  PipelineStatus status() const;
  PipelineProgress progress() const;

  /// Waits until the capture thread has finished (source ended or failed) and the detector
  /// thread has drained. For tests and offline runs; false on timeout.
  bool waitUntilDrained(std::chrono::milliseconds timeout);

 private:
  void captureLoop(std::stop_token stop);
  void detectLoop(std::stop_token stop);
  /// Logs the stages that failed on a frame, each at most once a minute.
  void logStageErrors(const FrameResults& results);
  /// Names the calling pipeline thread and gives it the configured priority.
  void prepareThisThread(const char* name);
  void setState(SourceState state, std::string message = {});
  void noteSourceEvent();
  /// The state as status() reports it: a live sensor that is not connected is reconnecting.
  SourceState reportedState(SourceState state) const;

  std::unique_ptr<FrameSource> source_;
  const std::string source_name_;
  DetectorChain chain_;
  FrameCache& cache_;
  SummaryHub& hub_;
  FrameTap* tap_;  // may be null
  const PipelineOptions options_;
  std::once_flag priority_refused_;
  LatencyTracker latency_;
  // Detector thread only: when each failing stage was last logged, and its failures since.
  struct StageErrorLog {
    std::chrono::steady_clock::time_point logged;
    std::uint64_t since_logged = 0;
  };
  std::map<std::string, StageErrorLog> stage_error_log_;

  mutable std::mutex mutex_;  // guards the fields below
  std::condition_variable_any changed_;
  std::shared_ptr<const Frame> waiting_;  // newest frame not yet taken by the detector thread
  bool capture_done_ = false;
  bool detecting_ = false;
  std::chrono::steady_clock::time_point detecting_since_;
  std::chrono::steady_clock::time_point last_source_event_ = std::chrono::steady_clock::now();
  SourceState state_ = SourceState::kStreaming;
  std::string last_error_;

  std::atomic<std::uint64_t> received_{0};
  std::atomic<std::uint64_t> processed_{0};
  std::atomic<std::uint64_t> skipped_{0};
  std::atomic<std::uint64_t> source_errors_{0};
  std::atomic<std::uint64_t> out_of_order_{0};
  std::uint64_t out_of_order_run_ = 0;  // capture thread only: consecutive refused frames

  std::jthread capture_thread_;
  std::jthread detect_thread_;
};

const char* toString(SourceState state);

}  // namespace shapesense
