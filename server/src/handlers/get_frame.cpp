#include <opencv2/imgcodecs.hpp>

#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
namespace {

std::string encodePng(const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  // Level 1: the size gain of higher levels is small on depth, the time cost is not.
  cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
  return {bytes.begin(), bytes.end()};
}

}  // namespace

grpc::Status handleGetFrame(const ServiceContext& context, const v1::GetFrameRequest& request,
                            v1::GetFrameResponse* response) {
  CachedFrame entry;
  if (auto status = lookupFrame(context.cache, request.at_ns(), entry); !status.ok()) return status;
  const Frame& frame = *entry.frame;
  toProto(entry, response->mutable_info());
  toProto(frame.intrinsics, response->mutable_intrinsics());
  if (!request.skip_depth()) response->set_depth_png(encodePng(frame.depth));
  if (!request.skip_rgb() && !frame.rgb.empty()) {
    // OpenCV holds colour as BGR and writes it into the PNG as RGB.
    response->set_rgb_png(encodePng(frame.rgb));
  }
  if (entry.results && entry.results->depth_stats) {
    toProto(*entry.results->depth_stats, response->mutable_depth_stats());
  }
  return grpc::Status::OK;
}

}  // namespace shapesense
