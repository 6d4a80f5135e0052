#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
namespace {

// Mode 4 boxes what the detectors made of the frame: its segments and planes.
grpc::Status segmentBoxOfFrame(const ServiceContext& context, std::int64_t at_ns, cv::Point p1,
                               cv::Point p2, CachedFrame& entry,
                               std::variant<BoxEstimate, BoxEstimationFailure>& result) {
  if (auto status = lookupProcessedFrame(context.cache, at_ns, entry); !status.ok()) return status;
  const FrameResults& results = *entry.results;
  if (!results.segmentation || !results.planes) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "box mode 4 needs the frame's segments and planes: the daemon runs with the "
            "segmentation or plane stage off"};
  }
  result = boxFromSegments(entry.frame->depth, entry.frame->intrinsics, p1, p2,
                           results.segmentation->labels, results.segmentation->segments,
                           results.planes->frame);
  return grpc::Status::OK;
}

}  // namespace

grpc::Status handleEstimateBox(const ServiceContext& context, const v1::EstimateBoxRequest& request,
                               v1::EstimateBoxResponse* response) {
  if (!request.has_p1() || !request.has_p2()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "p1 and p2 (two opposite ROI corners) are required"};
  }
  const int mode_value =
      request.mode() == v1::BOX_MODE_UNSPECIFIED ? 1 : static_cast<int>(request.mode());
  if (mode_value < 1 || mode_value > 4) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "unknown box mode " + std::to_string(mode_value) +
                ": use 1 (frustum aligned), 2 (axis aligned, ROI contains the box), 3 (axis "
                "aligned, ROI is the front face) or 4 (the segments the ROI covers)"};
  }
  const auto mode = static_cast<BoxMode>(mode_value);
  const cv::Point p1(request.p1().x(), request.p1().y());
  const cv::Point p2(request.p2().x(), request.p2().y());
  CachedFrame entry;
  std::variant<BoxEstimate, BoxEstimationFailure> result;
  if (mode == BoxMode::kSegments) {
    if (auto status = segmentBoxOfFrame(context, request.at_ns(), p1, p2, entry, result);
        !status.ok())
      return status;
  } else {
    if (auto status = lookupFrame(context.cache, request.at_ns(), entry); !status.ok())
      return status;
    result = estimateBox(entry.frame->depth, entry.frame->intrinsics, p1, p2, mode);
  }
  const Frame& frame = *entry.frame;
  if (auto* failure = std::get_if<BoxEstimationFailure>(&result)) {
    const auto code = failure->code == BoxEstimationError::kNoValidDepth
                          ? grpc::StatusCode::FAILED_PRECONDITION
                          : grpc::StatusCode::INVALID_ARGUMENT;
    return {code, failure->message};
  }
  const auto& box = std::get<BoxEstimate>(result);
  for (const auto& corner : box.corners) toProto(corner, response->add_corners());
  response->set_frame_timestamp_ns(frame.timestamp_ns);
  response->set_frame_sequence(frame.sequence);
  response->set_mode(static_cast<v1::BoxMode>(mode_value));
  toProto(box.stats, response->mutable_stats());
  response->set_collapsed_x(box.collapsed_x);
  response->set_collapsed_y(box.collapsed_y);
  return grpc::Status::OK;
}

}  // namespace shapesense
