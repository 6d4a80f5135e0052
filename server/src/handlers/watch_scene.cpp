// WatchScene: the scene model of every processed frame, as changes since the update this
// subscriber last received. Like Watch it holds no thread: the hub calls the stream back when a
// frame is queued, and one update at a time is built, then written. Building (the delta and the
// JPEG preview) runs on the query pool when there is one, so the detector thread that publishes
// frames never encodes images; a rate limit waits on a gRPC alarm. Latest wins throughout: the
// subscription keeps only the newest frame while an update is being built, written or held back
// by the rate, and the frames it replaced are counted in dropped_before.

#include <cmath>

#include <grpcpp/alarm.h>

#include "shapesense/server/handlers.h"
#include "shapesense/server/scene_update.h"

namespace shapesense {
namespace {

struct SceneStreamOptions {
  double max_rate_hz = 0;
  double full_every_s = 10;
  PreviewOptions preview;
};

class WatchSceneReactor final : public grpc::ServerWriteReactor<v1::SceneUpdate> {
 public:
  WatchSceneReactor(const ServiceContext& context, const SceneStreamOptions& options,
                    QueryPool* builders, std::unique_ptr<StreamQuota::Lease> lease)
      : hub_(context.hub),
        shutting_down_(context.shutting_down),
        session_id_(context.session_id),
        preview_(options.preview),
        schedule_(options.max_rate_hz, options.preview.rate_hz, options.full_every_s),
        builders_(builders),
        lease_(std::move(lease)) {
    auto subscription = hub_.subscribe(1, [this] { advance(); });
    {
      std::lock_guard lock(mutex_);
      subscription_ = std::move(subscription);
    }
    advance();  // a hub already closed (shutdown) ends the stream now
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mutex_);
    busy_ = false;
    if (!ok) {
      finishLocked(grpc::Status::OK);  // the client went away or cancelled
      return;
    }
    advanceLocked();
  }

  void OnCancel() override {
    std::lock_guard lock(mutex_);
    cancelled_ = true;
    if (waiting_) alarm_.Cancel();  // its callback then finishes the stream
    finishLocked(grpc::Status::CANCELLED);
  }

  void OnDone() override {
    hub_.unsubscribe(subscription_);  // no callback from the hub after this returns
    // The alarm and the pool call back outside gRPC's knowledge; neither is in flight once the
    // stream has finished, and each does all its work inside one hold of the lock, so taking it
    // here waits for the last of them to let go.
    { std::lock_guard lock(mutex_); }
    delete this;
  }

 private:
  /// Every entry point (hub, write done, alarm, pool) works under one hold of the lock and
  /// touches nothing after releasing it: once Finish is called, OnDone may delete this.
  void advance() {
    std::lock_guard lock(mutex_);
    advanceLocked();
  }

  /// Starts the next step when nothing is in flight: wait for the rate, or build an update of
  /// the newest frame.
  void advanceLocked() {
    if (!subscription_ || finished_) return;
    const bool ending =
        cancelled_ || subscription_->closed() || (shutting_down_ && shutting_down_->load());
    if (ending && waiting_) {
      alarm_.Cancel();  // a slow rate must not hold a shutdown; its callback finishes then
      return;
    }
    if (busy_) return;
    if (ending) {
      finishLocked(grpc::Status::OK);
      return;
    }
    if (!subscription_->hasPending()) return;
    const auto now = SceneSchedule::Clock::now();
    if (const auto wait = schedule_.untilNextUpdate(now); wait > wait.zero()) {
      busy_ = waiting_ = true;
      alarm_.Set(std::chrono::system_clock::now() +
                     std::chrono::duration_cast<std::chrono::system_clock::duration>(wait),
                 [this](bool) {
                   std::lock_guard lock(mutex_);
                   waiting_ = false;
                   endStepLocked();
                 });
      return;
    }
    auto item = subscription_->tryPop();
    if (!item) return;
    busy_ = true;
    const auto sent = schedule_.send(now);
    if (!builders_) {
      buildAndWriteLocked(*item, sent);
      return;
    }
    const bool queued = builders_->trySubmit([this, item = std::move(*item), sent](bool run) {
      std::lock_guard lock(mutex_);
      if (run && !finish_pending_ && !cancelled_) {
        buildAndWriteLocked(item, sent);
        return;
      }
      refused_ += 1 + item.dropped_before;  // the pool was too busy: the frame is dropped
      endStepLocked();
    });
    if (!queued) {
      refused_ += 1 + item->dropped_before;
      busy_ = false;
    }
  }

  void buildAndWriteLocked(const Subscription::Item& item, SceneSchedule::Sent sent) {
    if (!item.frame.results || !fillScene(item.frame, session_id_, update_).ok()) {
      endStepLocked();  // a frame without a scene (stages off): nothing to send
      return;
    }
    delta_.reduce(update_, sent.full);
    if (sent.preview) addPreview(*item.frame.frame, preview_, update_);
    update_.set_dropped_before(item.dropped_before + refused_);
    refused_ = 0;
    StartWrite(&update_);
  }

  /// A step that wrote nothing is over (an alarm fired, a build was refused or had nothing to
  /// send): finish if that was asked for meanwhile, else go on.
  void endStepLocked() {
    busy_ = false;
    if (finish_pending_) {
      finishLocked(pending_status_);
      return;
    }
    advanceLocked();
  }

  /// Finish once, and never with a step in flight: it completes and finishes then.
  void finishLocked(const grpc::Status& status) {
    if (finished_) return;
    if (busy_) {
      if (!finish_pending_) pending_status_ = status;
      finish_pending_ = true;
      return;
    }
    finished_ = true;
    Finish(finish_pending_ ? pending_status_ : status);
  }

  SummaryHub& hub_;
  const std::atomic<bool>* shutting_down_;
  const std::string session_id_;
  const PreviewOptions preview_;
  SceneSchedule schedule_;
  QueryPool* builders_;
  std::unique_ptr<StreamQuota::Lease> lease_;
  grpc::Alarm alarm_;

  std::mutex mutex_;
  std::shared_ptr<Subscription> subscription_;
  SceneDelta delta_;
  v1::SceneUpdate update_;     ///< the message being written
  std::uint64_t refused_ = 0;  ///< frames dropped since the last update besides the hub's count
  bool busy_ = false;          ///< a wait, build or write is in flight
  bool waiting_ = false;       ///< the alarm is set
  bool cancelled_ = false;
  bool finished_ = false;
  bool finish_pending_ = false;
  grpc::Status pending_status_;
};

/// A stream that only reports why it was refused.
class RefusedWatchScene final : public grpc::ServerWriteReactor<v1::SceneUpdate> {
 public:
  explicit RefusedWatchScene(const grpc::Status& status) { Finish(status); }
  void OnDone() override { delete this; }
};

grpc::Status parseStreamOptions(const v1::WatchSceneRequest& request, SceneStreamOptions& options) {
  const double rate = request.max_rate_hz();
  if (!std::isfinite(rate) || (rate != 0 && (rate < 0.1 || rate > 60))) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "max_rate_hz must be 0.1..60 updates a second (0 = every processed frame)"};
  }
  options.max_rate_hz = rate;
  const double full_every = request.full_every_s();
  if (!std::isfinite(full_every) || (full_every != 0 && (full_every < 0.1 || full_every > 3600))) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "full_every_s must be 0.1..3600 (0 = 10 s)"};
  }
  options.full_every_s = full_every == 0 ? 10.0 : full_every;
  return parsePreview(request.preview(), options.preview);
}

}  // namespace

grpc::ServerWriteReactor<v1::SceneUpdate>* startWatchScene(
    const ServiceContext& context, grpc::CallbackServerContext* server_context,
    const v1::WatchSceneRequest& request, QueryPool* builders) {
  SceneStreamOptions options;
  if (auto status = parseStreamOptions(request, options); !status.ok()) {
    return new RefusedWatchScene(status);
  }
  std::unique_ptr<StreamQuota::Lease> lease;
  if (context.watch_streams) {
    std::string refusal;
    lease = context.watch_streams->tryAcquire(server_context->peer(), refusal);
    if (!lease) return new RefusedWatchScene({grpc::StatusCode::RESOURCE_EXHAUSTED, refusal});
  }
  return new WatchSceneReactor(context, options, builders, std::move(lease));
}

}  // namespace shapesense
