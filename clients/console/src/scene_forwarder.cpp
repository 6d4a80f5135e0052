#include "scene_forwarder.h"

#include <algorithm>
#include <condition_variable>

#include <nlohmann/json.hpp>

#include "proto_json.h"
#include "shapesense/console/http_status.h"

namespace shapesense::console {
namespace {

constexpr double kFirstRetryS = 0.25;
constexpr double kLongestRetryS = 4.0;

/// Sleeps `seconds` unless `stop` is requested first.
void pause(const std::stop_token& stop, double seconds) {
  std::mutex mutex;
  std::condition_variable_any never;
  std::unique_lock lock(mutex);
  never.wait_for(lock, stop, std::chrono::duration<double>(seconds), [] { return false; });
}

}  // namespace

SceneForwarder::SceneForwarder(const std::shared_ptr<grpc::Channel>& channel,
                               v1::WatchSceneRequest request, std::shared_ptr<EventChannel> page,
                               LinkMeter& meter)
    : stub_(v1::ShapeSense::NewStub(channel)),
      request_(std::move(request)),
      page_(std::move(page)),
      meter_(meter),
      thread_([this](std::stop_token stop) { run(stop); }) {}

SceneForwarder::~SceneForwarder() {
  thread_.request_stop();
  page_->close();  // frees a pushScene() the thread may be waiting in
  {
    std::lock_guard lock(context_mutex_);
    if (open_context_) open_context_->TryCancel();
  }
  thread_.join();
}

void SceneForwarder::run(std::stop_token stop) {
  double retry_s = kFirstRetryS;
  while (!stop.stop_requested()) {
    const auto [status, any_update] = forwardOneStream(stop);
    if (stop.stop_requested()) break;
    if (any_update) retry_s = kFirstRetryS;  // it worked for a while: start the backoff over
    publishLink("reconnecting", status, retry_s);
    pause(stop, retry_s);
    retry_s = std::min(retry_s * 2, kLongestRetryS);
  }
}

std::pair<grpc::Status, bool> SceneForwarder::forwardOneStream(const std::stop_token& stop) {
  grpc::ClientContext context;
  {
    std::lock_guard lock(context_mutex_);
    if (stop.stop_requested()) return {grpc::Status::CANCELLED, false};
    open_context_ = &context;
  }
  auto reader = stub_->WatchScene(&context, request_);
  v1::SceneUpdate update;
  bool any_update = false;
  while (reader->Read(&update)) {
    meter_.received(update.ByteSizeLong());
    if (!any_update) publishLink("connected", grpc::Status::OK, 0);
    any_update = true;
    if (!page_->pushScene({"scene", toJson(update)})) {
      context.TryCancel();
      break;
    }
  }
  grpc::Status status = reader->Finish();
  std::lock_guard lock(context_mutex_);
  open_context_ = nullptr;
  if (status.ok()) status = {grpc::UNAVAILABLE, "the daemon ended the scene stream"};
  return {status, any_update};
}

void SceneForwarder::publishLink(const char* state, const grpc::Status& status, double retry_in_s) {
  nlohmann::json link = {{"state", state}};
  if (!status.ok()) {
    link["code"] = statusCodeName(status.error_code());
    link["message"] = status.error_message();
    link["retry_in_s"] = retry_in_s;
  }
  page_->pushNotice({"link", link.dump()});
}

}  // namespace shapesense::console
