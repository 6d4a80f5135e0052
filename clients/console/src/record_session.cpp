#include "record_session.h"

#include <nlohmann/json.hpp>

#include "proto_json.h"
#include "shapesense/console/http_status.h"

namespace shapesense::console {

RecordSession::RecordSession(v1::ShapeSense::Stub& stub, v1::RecordRequest request,
                             std::function<void(const SseEvent&)> publish, LinkMeter& meter)
    : stub_(stub),
      request_(std::move(request)),
      publish_(std::move(publish)),
      meter_(meter),
      thread_([this] { run(); }) {}

RecordSession::~RecordSession() {
  cancel();
  thread_.join();
}

grpc::Status RecordSession::waitForStart(std::chrono::milliseconds timeout) {
  if (started_future_.wait_for(timeout) != std::future_status::ready) {
    return {grpc::DEADLINE_EXCEEDED, "the daemon did not confirm the recording in time"};
  }
  return started_future_.get();
}

void RecordSession::cancel() { context_.TryCancel(); }

bool RecordSession::finished() const { return finished_; }

void RecordSession::run() {
  auto reader = stub_.Record(&context_, request_);
  v1::RecordProgress progress;
  bool started = false;
  bool done_published = false;
  nlohmann::json last_progress = nullptr;
  while (reader->Read(&progress)) {
    meter_.received(progress.ByteSizeLong());
    if (!started) started_.set_value(grpc::Status::OK);
    started = true;
    last_progress = nlohmann::json::parse(toJson(progress));
    done_published = progress.done();
    publish_({"record", nlohmann::json{{"state", progress.done() ? "done" : "recording"},
                                       {"progress", last_progress}}
                            .dump()});
  }
  const grpc::Status status = reader->Finish();
  if (!started) started_.set_value(status);
  finished_ = true;
  if (status.ok() && done_published) return;
  nlohmann::json end = {{"progress", last_progress}};
  if (status.ok() || status.error_code() == grpc::CANCELLED) {
    end["state"] = "done";  // cancelled by the operator: what was written is a recording
  } else {
    end["state"] = "failed";
    end["code"] = statusCodeName(status.error_code());
    end["message"] = status.error_message();
  }
  publish_({"record", end.dump()});
}

}  // namespace shapesense::console
