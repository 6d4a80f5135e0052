#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
grpc::Status handleGetFrame(const ServiceContext& context, const v1::GetFrameRequest& request,
                            v1::GetFrameResponse* response) {
  CachedFrame entry;
  if (auto status = lookupFrame(context.cache, request.at_ns(), entry); !status.ok()) return status;
  const Frame& frame = *entry.frame;
  toProto(entry, response->mutable_info());
  toProto(frame.intrinsics, response->mutable_intrinsics());
  PngCache& pngs = *context.pngs;
  if (!request.skip_depth()) {
    response->set_depth_png(
        *pngs.get(frame.sequence, frame.timestamp_ns, FrameImage::kDepth, frame.depth));
  }
  if (!request.skip_rgb() && !frame.rgb.empty()) {
    // OpenCV holds colour as BGR and writes it into the PNG as RGB.
    response->set_rgb_png(
        *pngs.get(frame.sequence, frame.timestamp_ns, FrameImage::kRgb, frame.rgb));
  }
  if (entry.results && entry.results->depth_stats) {
    toProto(*entry.results->depth_stats, response->mutable_depth_stats());
  }
  return grpc::Status::OK;
}

}  // namespace shapesense
