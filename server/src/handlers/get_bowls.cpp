#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleGetBowls(const ServiceContext& context, const v1::GetBowlsRequest& request,
                            v1::GetBowlsResponse* response) {
  CachedFrame entry;
  if (auto status = lookupProcessedFrame(context.cache, request.at_ns(), entry); !status.ok())
    return status;
  if (!entry.results->bowls) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the bowl stage is off; start shapesensed with --bowls on (and --models DIR if the "
            "models are not in the default folder)"};
  }
  toProto(entry, response->mutable_info());
  const auto timing = entry.results->timings_ms.find("bowls");
  if (timing != entry.results->timings_ms.end()) response->set_compute_ms(timing->second);
  for (const auto& bowl : *entry.results->bowls) toProto(bowl, response->add_bowls());
  return grpc::Status::OK;
}

}  // namespace shapesense
