// Record: the frames the source delivers for a while, written under the daemon's recordings root
// (recording_root.h) in the TUM layout (TumRecordingWriter) with camera.json, depth at the layout's
// 5000 units per metre (replays bit-identically up to 13.1 m, far past any Kinect-class reading).
// Frames come from the FrameTap (every delivered frame, processed or not) into a bounded queue this
// handler's thread drains, so a slow disk never slows the capture thread: it loses frames instead,
// counted in frames_dropped. The free space of the root's file system is checked before the first
// frame and then at every progress message: below the floor the recording stops with what it has,
// while the disk still has room for the index files to be complete.

#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>
#include <sstream>

#include "shapesense/driver/tum_recording.h"
#include "shapesense/server/handlers.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr std::size_t kMaxQueuedFrames = 64;
constexpr auto kProgressInterval = std::chrono::milliseconds(100);

bool sourceFinished(SourceState state) {
  return state == SourceState::kEnded || state == SourceState::kFailed ||
         state == SourceState::kStopped;
}

/// Clears the "a recording runs" flag when the call ends, however it ends.
struct RecordingFlag {
  std::atomic<bool>& flag;
  ~RecordingFlag() { flag = false; }
};

/// The queue between the capture thread (FrameTap listener) and this handler.
struct FrameQueue {
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<std::shared_ptr<const Frame>> frames;
  std::uint64_t dropped = 0;

  void push(const std::shared_ptr<const Frame>& frame) {
    {
      std::lock_guard lock(mutex);
      if (frames.size() >= kMaxQueuedFrames) {
        ++dropped;
        return;
      }
      frames.push_back(frame);
    }
    cv.notify_one();
  }
  std::shared_ptr<const Frame> pop(Clock::time_point until) {
    std::unique_lock lock(mutex);
    cv.wait_until(lock, until, [this] { return !frames.empty(); });
    if (frames.empty()) return nullptr;
    auto frame = std::move(frames.front());
    frames.pop_front();
    return frame;
  }
  std::uint64_t droppedCount() {
    std::lock_guard lock(mutex);
    return dropped;
  }
};

/// Why the request cannot be recorded, checked before anything is written; OK when it can.
grpc::Status refusal(const ServiceContext& context, const v1::RecordRequest& request) {
  if (context.frame_tap == nullptr) {
    return {grpc::StatusCode::UNIMPLEMENTED, "this server has no frame source to record from"};
  }
  const RecordLimits& limits = context.record;
  if (limits.root.empty()) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "this daemon has no recordings root: it does not record"};
  }
  if (request.dir().empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "dir is empty: name a new directory under the daemon's recordings root"};
  }
  const double seconds = request.seconds();
  if (!std::isfinite(seconds) || seconds <= 0.0 || seconds > limits.max_seconds) {
    std::ostringstream message;
    message << "seconds must be more than 0 and at most " << limits.max_seconds
            << " (shapesensed --record-max-seconds), got " << seconds;
    return {grpc::StatusCode::INVALID_ARGUMENT, message.str()};
  }
  const PipelineStatus status = context.pipeline_status();
  if (sourceFinished(status.state)) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the source " + status.source + " is " + toString(status.state) +
                ": no new frames to record (record a recording with `shapesense record --source "
                "SPEC`)"};
  }
  return grpc::Status::OK;
}

/// Free bytes of the recordings root's file system; one whose free space cannot be read
/// counts as full.
std::uintmax_t freeBytes(const RecordLimits& limits) {
  try {
    return limits.free_bytes(limits.root);
  } catch (const std::exception&) {
    return 0;
  }
}

std::string belowFloor(const RecordLimits& limits, std::uintmax_t free) {
  std::ostringstream message;
  message << "the recordings root's file system has " << free / (1 << 20)
          << " MB free, below the floor of " << limits.min_free_bytes / (1 << 20)
          << " MB (shapesensed --record-min-free-mb)";
  return message.str();
}

/// One running recording: the frames the tap queues, the writer of the recording directory and
/// the progress the client is told.
class RecordingSession {
 public:
  RecordingSession(const ServiceContext& context, fs::path dir,
                   const std::function<bool(const v1::RecordProgress&)>& write)
      : context_(context),
        dir_(std::move(dir)),
        write_(write),
        subscription_(std::make_unique<FrameTapSubscription>(
            *context.frame_tap,
            [this](const std::shared_ptr<const Frame>& frame) { queue_.push(frame); })) {}

  /// Past the deadline, or once the source has ended, takes no more frames.
  void stopTakingFramesIfDone(Clock::time_point deadline) {
    if (subscription_ &&
        (Clock::now() >= deadline || sourceFinished(context_.pipeline_status().state)))
      subscription_.reset();
  }
  bool takingFrames() const { return subscription_ != nullptr; }
  /// The next queued frame, waiting until `until` at most.
  std::shared_ptr<const Frame> nextFrame(Clock::time_point until) { return queue_.pop(until); }

  /// Appends a frame; a failure is an INTERNAL status saying what was kept.
  grpc::Status write(const Frame& frame) {
    try {
      if (!out_) {
        RecordingCamera camera;
        camera.intrinsics = frame.intrinsics;
        out_.emplace(dir_, camera);
      }
      out_->write(frame);
      ++written_;
    } catch (const std::exception& e) {
      return stopped(grpc::StatusCode::INTERNAL,
                     std::string("writing the recording failed: ") + e.what());
    }
    return grpc::Status::OK;
  }

  bool progressDue() const { return Clock::now() - last_sent_ >= kProgressInterval; }
  /// Tells the client how far the recording is; false when the client went away.
  bool sendProgress(bool done) {
    v1::RecordProgress message;
    message.set_frames_written(written_);
    message.set_seconds(std::chrono::duration<double>(Clock::now() - start_).count());
    message.set_done(done);
    message.set_dir(dir_.string());
    message.set_frames_dropped(queue_.droppedCount());
    last_sent_ = Clock::now();
    return write_(message);
  }

  /// A status that ends the recording early, saying that what was written stays usable.
  grpc::Status stopped(grpc::StatusCode code, const std::string& why) const {
    return {code, why + "; " + std::to_string(written_) + " frame(s) written to " + dir_.string() +
                      " stay a valid recording"};
  }

  Clock::time_point start() const { return start_; }

 private:
  const ServiceContext& context_;
  const fs::path dir_;
  const std::function<bool(const v1::RecordProgress&)>& write_;
  FrameQueue queue_;
  std::unique_ptr<FrameTapSubscription> subscription_;
  std::optional<TumRecordingWriter> out_;
  std::uint64_t written_ = 0;
  const Clock::time_point start_ = Clock::now();
  Clock::time_point last_sent_ = start_;
};

/// Why a running recording must stop now (cancelled, shutting down, disk below the floor, the
/// client gone), or OK.
grpc::Status reasonToStop(const ServiceContext& context,
                          const grpc::ServerContextBase* server_context,
                          RecordingSession& session) {
  if (server_context->IsCancelled())
    return session.stopped(grpc::StatusCode::CANCELLED, "recording cancelled");
  if (context.shuttingDown())
    return session.stopped(grpc::StatusCode::UNAVAILABLE, "the daemon is shutting down");
  if (!session.progressDue()) return grpc::Status::OK;
  if (const auto free = freeBytes(context.record); free < context.record.min_free_bytes)
    return session.stopped(grpc::StatusCode::RESOURCE_EXHAUSTED,
                           "recording stopped: " + belowFloor(context.record, free));
  if (!session.sendProgress(false))
    return session.stopped(grpc::StatusCode::CANCELLED, "the client went away");
  return grpc::Status::OK;
}

}  // namespace

grpc::Status handleRecord(const ServiceContext& context,
                          const grpc::ServerContextBase* server_context,
                          const v1::RecordRequest& request,
                          const std::function<bool(const v1::RecordProgress&)>& write) {
  if (grpc::Status refused = refusal(context, request); !refused.ok()) return refused;
  const RecordLimits& limits = context.record;
  if (context.recording->exchange(true)) {
    return {grpc::StatusCode::ABORTED,
            "another recording is running on this daemon (one at a time); retry when it is done"};
  }
  RecordingFlag clear_flag{*context.recording};

  if (const auto free = freeBytes(limits); free < limits.min_free_bytes) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED, belowFloor(limits, free) + "; nothing recorded"};
  }
  fs::path dir;
  if (grpc::Status made = makeRecordingDir(limits.root, request.dir(), dir); !made.ok()) {
    return made;
  }

  RecordingSession session(context, dir, write);
  const auto deadline = session.start() + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(request.seconds()));
  while (true) {
    // Once no more frames are taken, the queued ones are still written.
    session.stopTakingFramesIfDone(deadline);
    const auto now = Clock::now();
    const auto frame = session.nextFrame(
        session.takingFrames() ? std::min(deadline, now + kProgressInterval) : now);
    if (!frame && !session.takingFrames()) break;
    if (frame)
      if (grpc::Status written = session.write(*frame); !written.ok()) return written;
    if (grpc::Status stop = reasonToStop(context, server_context, session); !stop.ok()) return stop;
  }
  session.sendProgress(true);
  return grpc::Status::OK;
}

}  // namespace shapesense
