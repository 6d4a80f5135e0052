#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleWatch(const ServiceContext& context, grpc::ServerContext* server_context,
                         const v1::WatchRequest& request,
                         grpc::ServerWriter<v1::FrameSummary>* writer) {
  if (request.max_pending() > 1024) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "max_pending must be at most 1024"};
  }
  const std::size_t max_pending =
      request.max_pending() == 0 ? SummaryHub::kDefaultMaxPending : request.max_pending();
  auto subscription = context.hub.subscribe(max_pending);
  // The wait is short so a cancelled client or a shutdown ends the stream promptly.
  constexpr std::chrono::milliseconds kPoll{100};
  while (!server_context->IsCancelled() && !context.shuttingDown() && !subscription->closed()) {
    auto item = subscription->pop(kPoll);
    if (!item) continue;
    v1::FrameSummary summary;
    toProto(item->frame, summary.mutable_info());
    summary.set_dropped_before(item->dropped_before);
    if (const auto& results = item->frame.results) {
      if (results->depth_stats) toProto(*results->depth_stats, summary.mutable_depth_stats());
      if (results->planes) {
        summary.set_planes(static_cast<std::uint32_t>(results->planes->frame.planes.size()));
      }
      if (results->segmentation) {
        summary.set_segments(static_cast<std::uint32_t>(results->segmentation->segments.size()));
      }
      if (results->bowls) summary.set_bowls(static_cast<std::uint32_t>(results->bowls->size()));
      for (const auto& [stage, ms] : results->timings_ms) {
        auto* timing = summary.add_timings();
        timing->set_stage(stage);
        timing->set_ms(ms);
      }
    }
    if (!writer->Write(summary)) break;  // the client went away
  }
  context.hub.unsubscribe(subscription);
  return grpc::Status::OK;
}

}  // namespace shapesense
