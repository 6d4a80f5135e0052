#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleGetDetectedBoxes(const ServiceContext& context,
                                    const v1::GetDetectedBoxesRequest& request,
                                    v1::GetDetectedBoxesResponse* response) {
  CachedFrame entry;
  if (auto status = lookupProcessedFrame(context.cache, request.at_ns(), entry); !status.ok())
    return status;
  response->set_frame_timestamp_ns(entry.frame->timestamp_ns);
  for (const auto& object : entry.results->object_boxes) {
    auto* box = response->add_boxes();
    box->set_source("segment");
    box->set_source_id(object.segment_id);
    box->mutable_p1()->set_x(object.roi.x);
    box->mutable_p1()->set_y(object.roi.y);
    box->mutable_p2()->set_x(object.roi.x + object.roi.width - 1);
    box->mutable_p2()->set_y(object.roi.y + object.roi.height - 1);
    for (const auto& corner : object.box.corners) toProto(corner, box->add_corners());
  }
  if (entry.results->bowls) {
    const auto& bowls = *entry.results->bowls;
    for (std::size_t i = 0; i < bowls.size(); ++i) {
      if (!bowls[i].box) continue;  // no depth in its image box: nothing to place in 3D
      const cv::Rect& roi = bowls[i].detection.box;
      auto* box = response->add_boxes();
      box->set_source("bowl");
      box->set_source_id(static_cast<std::uint32_t>(i));
      box->mutable_p1()->set_x(roi.x);
      box->mutable_p1()->set_y(roi.y);
      box->mutable_p2()->set_x(roi.x + roi.width - 1);
      box->mutable_p2()->set_y(roi.y + roi.height - 1);
      for (const auto& corner : bowls[i].box->corners) toProto(corner, box->add_corners());
      box->set_score(bowls[i].detection.score);
      box->set_view(bowls[i].detection.view);
    }
  }
  return grpc::Status::OK;
}

}  // namespace shapesense
