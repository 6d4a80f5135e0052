#pragma once
// One page's live scene: a WatchScene stream whose updates go to the page as `scene` events,
// reopened with backoff whenever it ends (daemon unreachable, restarted, overloaded), with a
// `link` event for each change of the link's state.

#include <memory>
#include <mutex>
#include <thread>

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>

#include "event_channel.h"
#include "link_meter.h"
#include "shapesense/v1/shapesense.grpc.pb.h"

namespace shapesense::console {

class SceneForwarder {
 public:
  /// Starts the stream at once; updates go to `page` until the forwarder is destroyed.
  SceneForwarder(const std::shared_ptr<grpc::Channel>& channel, v1::WatchSceneRequest request,
                 std::shared_ptr<EventChannel> page, LinkMeter& meter);
  /// Cancels the stream and waits for its thread.
  ~SceneForwarder();
  SceneForwarder(const SceneForwarder&) = delete;
  SceneForwarder& operator=(const SceneForwarder&) = delete;

 private:
  void run(std::stop_token stop);
  /// Reads one stream until it ends; returns its status and whether any update arrived.
  std::pair<grpc::Status, bool> forwardOneStream(const std::stop_token& stop);
  void publishLink(const char* state, const grpc::Status& status, double retry_in_s);

  std::unique_ptr<v1::ShapeSense::Stub> stub_;
  v1::WatchSceneRequest request_;
  std::shared_ptr<EventChannel> page_;
  LinkMeter& meter_;
  std::mutex context_mutex_;
  grpc::ClientContext* open_context_ = nullptr;  // the stream being read, to cancel it
  std::jthread thread_;                          // last: starts once the rest is ready
};

}  // namespace shapesense::console
