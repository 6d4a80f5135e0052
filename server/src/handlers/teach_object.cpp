#include <cmath>
#include <stdexcept>

#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/recognition/object_model.h"
#include "shapesense/core/recognition/object_model_file.h"
#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
namespace {

// The farthest a model found in the frame it was taught from may lie from where it was taught
// (m): past this, what matched is something else.
constexpr double kMaxSelfFindOffsetM = 0.02;

// The object's pixels as box mode 4 finds them (the EstimateBox handler's rule), so that
// what an operator sees boxed is what gets taught.
grpc::Status objectOfFrame(const ServiceContext& context, std::int64_t at_ns, cv::Point p1,
                           cv::Point p2, CachedFrame& entry, cv::Mat& mask) {
  if (auto status = lookupProcessedFrame(context.cache, at_ns, entry); !status.ok()) return status;
  const FrameResults& results = *entry.results;
  if (!results.segmentation || !results.planes) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "teaching needs the frame's segments and planes: the daemon runs with the "
            "segmentation or plane stage off"};
  }
  auto object = objectUnderRoi(entry.frame->depth, entry.frame->intrinsics, p1, p2,
                               results.segmentation->labels, results.segmentation->segments,
                               results.planes->frame);
  if (auto* failure = std::get_if<BoxEstimationFailure>(&object)) {
    const auto code = failure->code == BoxEstimationError::kNoValidDepth
                          ? grpc::StatusCode::FAILED_PRECONDITION
                          : grpc::StatusCode::INVALID_ARGUMENT;
    return {code, failure->message};
  }
  mask = std::get<RoiObject>(object).mask;
  return grpc::Status::OK;
}

}  // namespace

grpc::Status handleTeachObject(const ServiceContext& context, const v1::TeachObjectRequest& request,
                               v1::TeachObjectResponse* response) {
  ObjectModelStore* store = nullptr;
  if (auto status = objectModelsOf(context, store); !status.ok()) return status;
  const std::string& name = request.name();
  if (!isValidObjectModelName(name)) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "name '" + name.substr(0, 80) +
                "' cannot name an object: use 1-64 letters, digits, '-', '_' or '.', not "
                "starting with '.'"};
  }
  if (!request.has_p1() || !request.has_p2()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "p1 and p2 (two opposite corners of an ROI around the object) are required"};
  }
  // Before the work of teaching: a name taken or a full folder is known at once.
  if (auto status = store->admits(name, request.replace()); !status.ok()) return status;
  CachedFrame entry;
  cv::Mat mask;
  if (auto status = objectOfFrame(context, request.at_ns(), {request.p1().x(), request.p1().y()},
                                  {request.p2().x(), request.p2().y()}, entry, mask);
      !status.ok())
    return status;
  // The frame's surface serves teaching (its flat faces give the support) and the check below.
  bool reused = false;
  const auto scene = context.scene_surfaces->get(*entry.frame, store->params(), reused);
  ObjectModel model;
  try {
    model = teachObjectModel(name, entry.frame->depth, entry.frame->intrinsics, mask,
                             store->params(), &scene->flatFaces());
  } catch (const std::invalid_argument& e) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            std::string("this object cannot be taught: ") + e.what()};
  }
  // A model FindObjects cannot find even in the frame it was taught from would only ever be
  // missed: say so now, while the operator still looks at the object.
  const auto found = findObject(model, *scene);
  if (!found) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "this object cannot be taught: its shape from this view (" +
                std::to_string(model.features.size()) +
                " features) is not found again even in this frame; teach it from a view that "
                "shows more of its corners and edges"};
  }
  // ...and one found somewhere else in that frame would be found there again: its shape from
  // this view is not its own. The model's frame is this frame's camera, so the object found
  // where it is leaves its centre in place (a round one may turn about its axis).
  const double offset_m = (found->camera_from_model * model.box.centre - model.box.centre).norm();
  if (offset_m > kMaxSelfFindOffsetM) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "this object cannot be taught: its shape from this view is found " +
                std::to_string(static_cast<int>(std::lround(100.0 * offset_m))) +
                " cm away from it in this very frame, so it would be found there too; teach it "
                "from a view that shows what sets it apart"};
  }
  StoredObjectModel stored;
  bool replaced = false;
  if (auto status = store->add(std::move(model), request.replace(), stored, replaced); !status.ok())
    return status;
  toProto(stored, response->mutable_model());
  response->set_frame_timestamp_ns(entry.frame->timestamp_ns);
  response->set_frame_sequence(entry.frame->sequence);
  response->set_replaced(replaced);
  return grpc::Status::OK;
}

}  // namespace shapesense
