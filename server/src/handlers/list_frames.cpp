#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleListFrames(const ServiceContext& context, const v1::ListFramesRequest& request,
                              v1::ListFramesResponse* response) {
  if (request.from_ns() < 0 || request.to_ns() < 0) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "from_ns and to_ns must not be negative"};
  }
  if (request.to_ns() != 0 && request.from_ns() > request.to_ns()) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "from_ns is after to_ns: the range is empty"};
  }
  auto frames = context.cache.list(request.from_ns(), request.to_ns());
  std::size_t first = 0;
  if (request.limit() != 0 && frames.size() > request.limit())
    first = frames.size() - request.limit();
  for (std::size_t i = first; i < frames.size(); ++i) toProto(frames[i], response->add_frames());
  toProto(context.cache.range(), response->mutable_cache());
  return grpc::Status::OK;
}

}  // namespace shapesense
