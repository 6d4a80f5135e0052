#include "shapesense/server/handlers.h"

namespace shapesense {

grpc::Status handleGetDetectedBoxes(const ServiceContext& context,
                                    const v1::GetDetectedBoxesRequest& request,
                                    v1::GetDetectedBoxesResponse* response) {
  CachedFrame entry;
  if (auto status = lookupFrame(context.cache, request.at_ns(), entry); !status.ok()) return status;
  response->set_frame_timestamp_ns(entry.frame->timestamp_ns);
  // Boxes come from bowl and segment detections; neither stage exists yet, so the list is empty.
  return grpc::Status::OK;
}

}  // namespace shapesense
