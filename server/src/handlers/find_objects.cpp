#include <algorithm>
#include <chrono>
#include <set>

#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/recognition/object_model_file.h"
#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
namespace {

void quaternionToProto(const Eigen::Quaterniond& q, v1::Quaternion* out) {
  out->set_w(q.w());
  out->set_x(q.x());
  out->set_y(q.y());
  out->set_z(q.z());
}

std::array<Eigen::Vector3d, 8> boxCorners(const OrientedBox& box) {
  // The order v1::OrientedBox.corners documents: a face loop at -z, the same loop at +z.
  constexpr int kSigns[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  std::array<Eigen::Vector3d, 8> corners;
  const Eigen::Vector3d half = 0.5 * box.size.cast<double>();
  const Eigen::Matrix3d axes = box.axes.cast<double>();
  for (int face = 0; face < 2; ++face) {
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d local(kSigns[i][0] * half.x(), kSigns[i][1] * half.y(),
                                  (face == 0 ? -1 : 1) * half.z());
      corners[face * 4 + i] = box.centre.cast<double>() + axes * local;
    }
  }
  return corners;
}

// The image bounds of the corners in front of the camera, clipped to the image.
cv::Rect imageBox(const std::array<Eigen::Vector3d, 8>& corners,
                  const CameraIntrinsics& intrinsics) {
  constexpr double kNearestZ = 0.01;  // closer corners project to nonsense
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  bool any = false;
  for (const auto& corner : corners) {
    if (corner.z() < kNearestZ) continue;
    const Eigen::Vector2d pixel = intrinsics.project(corner);
    x0 = std::min(x0, pixel.x());
    y0 = std::min(y0, pixel.y());
    x1 = std::max(x1, pixel.x());
    y1 = std::max(y1, pixel.y());
    any = true;
  }
  if (!any) return {};
  const cv::Rect image(0, 0, intrinsics.width, intrinsics.height);
  const auto clamp = [](double value) { return static_cast<int>(std::clamp(value, -1e6, 1e6)); };
  const cv::Point tl(clamp(std::floor(x0)), clamp(std::floor(y0)));
  const cv::Point br(clamp(std::ceil(x1)) + 1, clamp(std::ceil(y1)) + 1);
  return cv::Rect(tl, br) & image;
}

void detectionToProto(const ObjectDetection& detection, const CameraIntrinsics& intrinsics,
                      v1::ObjectDetection* out) {
  out->set_name(detection.name);
  toProto(detection.camera_from_model.translation().cast<double>().eval(),
          out->mutable_translation());
  quaternionToProto(
      Eigen::Quaterniond(detection.camera_from_model.linear().cast<double>()).normalized(),
      out->mutable_rotation());
  out->set_score(detection.score);
  out->set_confirmed_points(static_cast<std::uint32_t>(detection.confirmed_points));
  out->set_feature_inliers(static_cast<std::uint32_t>(detection.feature_inliers));
  auto* box = out->mutable_box();
  toProto(detection.box.centre.cast<double>().eval(), box->mutable_centre());
  Eigen::Matrix3d axes = detection.box.axes.cast<double>();
  if (axes.determinant() < 0) axes.col(2) = -axes.col(2);  // a rotation, whatever the core gives
  quaternionToProto(Eigen::Quaterniond(axes).normalized(), box->mutable_orientation());
  toProto(detection.box.size.cast<double>().eval(), box->mutable_size());
  const auto corners = boxCorners(detection.box);
  for (const auto& corner : corners) toProto(corner, box->add_corners());
  toProto(imageBox(corners, intrinsics), out->mutable_image_box());
}

// The models the request names (every one for none), or why not.
grpc::Status modelsToFind(const ObjectModelStore& store, const v1::FindObjectsRequest& request,
                          std::vector<StoredObjectModel>& models) {
  if (request.names().empty()) {
    models = store.list();
    return grpc::Status::OK;
  }
  std::set<std::string> seen;
  for (const auto& name : request.names()) {
    if (!isValidObjectModelName(name)) {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              "'" + name.substr(0, 80) +
                  "' cannot name a taught object (1-64 letters, digits, '-', '_' or '.')"};
    }
    if (!seen.insert(name).second) continue;
    auto stored = store.get(name);
    if (!stored) {
      return {grpc::StatusCode::NOT_FOUND,
              "no object named '" + name +
                  "' is taught: ListObjectModels lists them, TeachObject teaches one"};
    }
    models.push_back(std::move(*stored));
  }
  return grpc::Status::OK;
}

}  // namespace

grpc::Status handleFindObjects(const ServiceContext& context, const v1::FindObjectsRequest& request,
                               v1::FindObjectsResponse* response) {
  const auto start = std::chrono::steady_clock::now();
  ObjectModelStore* store = nullptr;
  if (auto status = objectModelsOf(context, store); !status.ok()) return status;
  std::vector<StoredObjectModel> models;
  if (auto status = modelsToFind(*store, request, models); !status.ok()) return status;
  CachedFrame entry;
  if (auto status = lookupFrame(context.cache, request.at_ns(), entry); !status.ok()) return status;
  const Frame& frame = *entry.frame;
  response->set_frame_timestamp_ns(frame.timestamp_ns);
  response->set_frame_sequence(frame.sequence);
  if (!models.empty()) {
    bool reused = false;
    const auto scene = context.scene_surfaces->get(frame, store->params(), reused);
    response->set_surface_reused(reused);
    std::vector<ObjectDetection> detections;
    for (const auto& stored : models) {
      if (context.shuttingDown()) return {grpc::StatusCode::UNAVAILABLE, "the daemon stops"};
      if (auto detection = findObject(*stored.model, *scene)) {
        detections.push_back(std::move(*detection));
      }
    }
    std::stable_sort(detections.begin(), detections.end(),
                     [](const auto& a, const auto& b) { return a.score > b.score; });
    for (const auto& detection : detections)
      detectionToProto(detection, frame.intrinsics, response->add_detections());
  }
  response->set_compute_ms(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  return grpc::Status::OK;
}

}  // namespace shapesense
