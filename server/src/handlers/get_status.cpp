#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleGetStatus(const ServiceContext& context, const v1::GetStatusRequest&,
                             v1::GetStatusResponse* response) {
  const PipelineStatus status = context.pipeline_status();
  response->set_version(SHAPESENSE_VERSION);
  response->set_source(status.source);
  response->set_source_state(toProto(status.state));
  response->set_source_message(status.last_error);
  response->set_frames_received(status.frames_received);
  response->set_frames_processed(status.frames_processed);
  response->set_frames_skipped(status.frames_skipped);
  response->set_source_errors(status.source_errors);
  response->set_frames_out_of_order(status.frames_out_of_order);
  toProto(context.cache.range(), response->mutable_cache());
  for (const auto& stage : status.stages) {
    auto* out = response->add_stages();
    out->set_stage(stage.stage);
    out->set_runs(stage.runs);
    out->set_last_ms(stage.last_ms);
    out->set_median_ms(stage.median_ms);
    out->set_p95_ms(stage.p95_ms);
  }
  for (const auto& name : status.detectors) response->add_detectors(name);
  const std::chrono::duration<double> uptime = std::chrono::steady_clock::now() - context.started;
  response->set_uptime_s(uptime.count());
  response->set_session_id(context.session_id);
  response->set_source_live(status.health.live);
  response->set_source_connected(status.health.connected);
  response->set_source_reconnects(status.health.reconnects);
  response->set_source_disconnects(status.health.disconnects);
  response->set_source_dropped_frames(status.health.dropped_frames);
  for (const MethodLatency& method : context.call_latencies->snapshot()) {
    auto* out = response->add_calls();
    out->set_method(method.method);
    out->set_answered(method.answered);
    out->set_refused(method.refused);
    out->set_failed(method.failed);
    for (const double bound : MethodLatency::kBucketUpperMs) out->add_bucket_upper_ms(bound);
    for (const std::uint64_t n : method.answered_by_bucket) out->add_answered_by_bucket(n);
  }
  return grpc::Status::OK;
}

}  // namespace shapesense
