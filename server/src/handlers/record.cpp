// Record: the frames the source delivers for a while, written on the daemon's machine in the TUM
// layout (TumRecordingWriter) with camera.json, depth at the layout's 5000 units per metre
// (replays bit-identically up to 13.1 m, far past any Kinect-class reading). Frames come from the
// FrameTap (every delivered frame, processed or not) into a bounded queue this handler's thread
// drains, so a slow disk never slows the capture thread: it loses frames instead, counted in
// frames_dropped.

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
constexpr double kMaxSeconds = 86400.0;

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

}  // namespace

grpc::Status handleRecord(const ServiceContext& context, grpc::ServerContext* server_context,
                          const v1::RecordRequest& request,
                          grpc::ServerWriter<v1::RecordProgress>* writer) {
  if (context.frame_tap == nullptr) {
    return {grpc::StatusCode::UNIMPLEMENTED, "this server has no frame source to record from"};
  }
  if (request.dir().empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "dir is empty: give an absolute directory path on the daemon's machine"};
  }
  const fs::path dir(request.dir());
  if (!dir.is_absolute()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "dir '" + request.dir() +
                "' is relative: the daemon writes on its own machine, give an absolute path"};
  }
  const double seconds = request.seconds();
  if (!std::isfinite(seconds) || seconds <= 0.0 || seconds > kMaxSeconds) {
    std::ostringstream message;
    message << "seconds must be more than 0 and at most " << kMaxSeconds << ", got " << seconds;
    return {grpc::StatusCode::INVALID_ARGUMENT, message.str()};
  }
  const PipelineStatus status = context.pipeline_status();
  if (sourceFinished(status.state)) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the source " + status.source + " is " + toString(status.state) +
                ": no new frames to record (record a recording with `shapesense record --source "
                "SPEC`)"};
  }
  if (context.recording->exchange(true)) {
    return {grpc::StatusCode::ABORTED,
            "another recording is running on this daemon (one at a time); retry when it is done"};
  }
  RecordingFlag clear_flag{*context.recording};

  std::error_code error;
  if (fs::exists(dir, error)) {
    if (!fs::is_directory(dir, error)) {
      return {grpc::StatusCode::FAILED_PRECONDITION,
              "'" + dir.string() + "' exists and is not a directory"};
    }
    if (!fs::is_empty(dir, error)) {
      return {grpc::StatusCode::FAILED_PRECONDITION,
              "'" + dir.string() + "' is not empty: choose a new directory (or empty this one)"};
    }
  }
  fs::create_directories(dir, error);
  if (error) {
    return {error == std::errc::permission_denied ? grpc::StatusCode::PERMISSION_DENIED
                                                  : grpc::StatusCode::FAILED_PRECONDITION,
            "cannot create '" + dir.string() + "' on the daemon's machine: " + error.message()};
  }

  FrameQueue queue;
  auto subscription = std::make_unique<FrameTapSubscription>(
      *context.frame_tap,
      [&queue](const std::shared_ptr<const Frame>& frame) { queue.push(frame); });
  const auto start = Clock::now();
  const auto deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::optional<TumRecordingWriter> out;
  std::uint64_t written = 0;
  auto last_sent = start;

  const auto progress = [&](bool done) {
    v1::RecordProgress message;
    message.set_frames_written(written);
    message.set_seconds(std::chrono::duration<double>(Clock::now() - start).count());
    message.set_done(done);
    message.set_dir(dir.string());
    message.set_frames_dropped(queue.droppedCount());
    last_sent = Clock::now();
    return writer->Write(message);
  };
  const auto stopped_after = [&] {
    return std::to_string(written) + " frame(s) written to " + dir.string() +
           " stay a valid recording";
  };

  while (true) {
    const auto now = Clock::now();
    // Past the deadline, or the source has ended: take no more frames, write those queued.
    if (subscription && (now >= deadline || sourceFinished(context.pipeline_status().state))) {
      subscription.reset();
    }
    auto frame = queue.pop(subscription ? std::min(deadline, now + kProgressInterval) : now);
    if (!frame && !subscription) break;
    if (frame) {
      try {
        if (!out) {
          RecordingCamera camera;
          camera.intrinsics = frame->intrinsics;
          out.emplace(dir, camera);
        }
        out->write(*frame);
        ++written;
      } catch (const std::exception& e) {
        return {grpc::StatusCode::INTERNAL,
                std::string("writing the recording failed: ") + e.what() + "; " + stopped_after()};
      }
    }
    if (server_context->IsCancelled()) {
      return {grpc::StatusCode::CANCELLED, "recording cancelled; " + stopped_after()};
    }
    if (context.shuttingDown()) {
      return {grpc::StatusCode::UNAVAILABLE, "the daemon is shutting down; " + stopped_after()};
    }
    if (Clock::now() - last_sent >= kProgressInterval && !progress(false)) {
      return {grpc::StatusCode::CANCELLED, "the client went away; " + stopped_after()};
    }
  }
  progress(true);
  return grpc::Status::OK;
}

}  // namespace shapesense
