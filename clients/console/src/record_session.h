#pragma once
// A recording the page started: the Record stream read on a thread of its own, its progress
// handed to every open page as `record` events, cancelled by the page or when the console stops.

#include <atomic>
#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>

#include <grpcpp/client_context.h>

#include "event_channel.h"
#include "link_meter.h"
#include "shapesense/v1/shapesense.grpc.pb.h"

namespace shapesense::console {

class RecordSession {
 public:
  /// Starts the Record call; every progress message and the end go to `publish` as `record`
  /// events ({"state": "recording"|"done"|"failed", "progress": RecordProgress, "code",
  /// "message"}).
  RecordSession(v1::ShapeSense::Stub& stub, v1::RecordRequest request,
                std::function<void(const SseEvent&)> publish, LinkMeter& meter);
  /// Cancels the recording (what was written stays a valid recording) and waits for its end.
  ~RecordSession();
  RecordSession(const RecordSession&) = delete;
  RecordSession& operator=(const RecordSession&) = delete;

  /// How the call started: OK once the first progress arrived, else the status it ended with.
  /// DEADLINE_EXCEEDED when neither happened within `timeout`.
  grpc::Status waitForStart(std::chrono::milliseconds timeout);
  /// Ends the recording early.
  void cancel();
  bool finished() const;

 private:
  void run();

  v1::ShapeSense::Stub& stub_;
  v1::RecordRequest request_;
  std::function<void(const SseEvent&)> publish_;
  LinkMeter& meter_;
  grpc::ClientContext context_;
  std::promise<grpc::Status> started_;
  std::shared_future<grpc::Status> started_future_ = started_.get_future().share();
  std::atomic<bool> finished_ = false;
  std::thread thread_;  // last: starts once the rest is ready
};

}  // namespace shapesense::console
