#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleGetPlanes(const ServiceContext& context, const v1::GetPlanesRequest& request,
                             v1::GetPlanesResponse* response) {
  if (!v1::GetPlanesRequest::View_IsValid(request.view())) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "view must be FRAME (0) or ACCUMULATED (1)"};
  }
  CachedFrame entry;
  if (auto status = lookupProcessedFrame(context.cache, request.at_ns(), entry); !status.ok())
    return status;
  if (!entry.results->planes) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the plane stage is off; start shapesensed with --planes hough or --planes ransac"};
  }
  const PlaneResult& result = *entry.results->planes;
  response->set_frame_timestamp_ns(entry.frame->timestamp_ns);
  response->set_detector(result.detector);
  const auto timing = entry.results->timings_ms.find("planes");
  if (timing != entry.results->timings_ms.end()) response->set_compute_ms(timing->second);
  const bool accumulated = request.view() == v1::GetPlanesRequest::ACCUMULATED;
  const auto& planes = accumulated ? result.accumulated : result.frame.planes;
  for (const auto& plane : planes) toProto(plane, !request.skip_polygons(), response->add_planes());
  if (!accumulated && !request.skip_labels()) {
    response->set_labels_png(*context.pngs->get(entry.frame->sequence, entry.frame->timestamp_ns,
                                                FrameImage::kPlaneLabels, result.frame.labels));
  }
  return grpc::Status::OK;
}

}  // namespace shapesense
