// Watch: a summary of every processed frame, written without a thread of its own. The hub calls
// the stream back when a frame is queued for it; the stream then writes if no write is in
// flight, and otherwise leaves the summary in its subscription, where a newer one replaces it
// (counted, and reported as dropped_before with the next summary sent). So a slow client has
// at most one summary being written and max_pending waiting, whatever it does.

#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
namespace {

void toSummary(const Subscription::Item& item, v1::FrameSummary& summary) {
  summary.Clear();
  toProto(item.frame, summary.mutable_info());
  summary.set_dropped_before(item.dropped_before);
  if (const auto& results = item.frame.results) {
    if (results->depth_stats) toProto(*results->depth_stats, summary.mutable_depth_stats());
    if (results->planes) {
      summary.set_planes(static_cast<std::uint32_t>(results->planes->frame.planes.size()));
    }
    if (results->segmentation) {
      summary.set_segments(static_cast<std::uint32_t>(results->segmentation->segments.size()));
    }
    if (results->bowls) summary.set_bowls(static_cast<std::uint32_t>(results->bowls->size()));
    if (results->taught_objects) {
      summary.set_taught_objects(static_cast<std::uint32_t>(results->taught_objects->size()));
    }
    for (const auto& [stage, ms] : results->timings_ms) {
      auto* timing = summary.add_timings();
      timing->set_stage(stage);
      timing->set_ms(ms);
    }
  }
}

class WatchReactor final : public grpc::ServerWriteReactor<v1::FrameSummary> {
 public:
  WatchReactor(const ServiceContext& context, std::size_t max_pending,
               std::unique_ptr<StreamQuota::Lease> lease)
      : hub_(context.hub), shutting_down_(context.shutting_down), lease_(std::move(lease)) {
    auto subscription = hub_.subscribe(max_pending, [this] { sendNext(); });
    {
      std::lock_guard lock(mutex_);
      subscription_ = std::move(subscription);
    }
    sendNext();  // a hub already closed (shutdown) ends the stream now
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard lock(mutex_);
      writing_ = false;
      if (!ok) finishLocked(grpc::Status::OK);  // the client went away or cancelled
    }
    sendNext();
  }

  void OnCancel() override {
    std::lock_guard lock(mutex_);
    finishLocked(grpc::Status::CANCELLED);
  }

  void OnDone() override {
    hub_.unsubscribe(subscription_);  // no callback from the hub after this returns
    delete this;
  }

 private:
  void sendNext() {
    std::lock_guard lock(mutex_);
    if (!subscription_ || finished_ || writing_) return;
    if (subscription_->closed() || (shutting_down_ && shutting_down_->load())) {
      finishLocked(grpc::Status::OK);
      return;
    }
    auto item = subscription_->tryPop();
    if (!item) return;
    toSummary(*item, summary_);
    writing_ = true;
    StartWrite(&summary_);
  }

  /// Finish once, and never with a write in flight: a write in flight completes (ok = false
  /// once cancelled) and OnWriteDone finishes then.
  void finishLocked(const grpc::Status& status) {
    if (finished_) return;
    if (writing_) {
      pending_status_ = status;
      finish_after_write_ = true;
      return;
    }
    finished_ = true;
    Finish(finish_after_write_ ? pending_status_ : status);
  }

  SummaryHub& hub_;
  const std::atomic<bool>* shutting_down_;
  std::unique_ptr<StreamQuota::Lease> lease_;
  std::mutex mutex_;
  std::shared_ptr<Subscription> subscription_;
  v1::FrameSummary summary_;  ///< the message being written
  bool writing_ = false;
  bool finished_ = false;
  bool finish_after_write_ = false;
  grpc::Status pending_status_;
};

/// A stream that only reports why it was refused.
class RefusedWatch final : public grpc::ServerWriteReactor<v1::FrameSummary> {
 public:
  explicit RefusedWatch(const grpc::Status& status) { Finish(status); }
  void OnDone() override { delete this; }
};

}  // namespace

grpc::ServerWriteReactor<v1::FrameSummary>* startWatch(const ServiceContext& context,
                                                       grpc::CallbackServerContext* server_context,
                                                       const v1::WatchRequest& request) {
  if (request.max_pending() > 1024) {
    return new RefusedWatch(
        {grpc::StatusCode::INVALID_ARGUMENT, "max_pending must be at most 1024"});
  }
  std::unique_ptr<StreamQuota::Lease> lease;
  if (context.watch_streams) {
    std::string refusal;
    lease = context.watch_streams->tryAcquire(server_context->peer(), refusal);
    if (!lease) return new RefusedWatch({grpc::StatusCode::RESOURCE_EXHAUSTED, refusal});
  }
  const std::size_t max_pending =
      request.max_pending() == 0 ? SummaryHub::kDefaultMaxPending : request.max_pending();
  return new WatchReactor(context, max_pending, std::move(lease));
}

}  // namespace shapesense
