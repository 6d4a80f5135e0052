#include <algorithm>
#include <chrono>
#include <set>

#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/recognition/object_model_file.h"
#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {
namespace {

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
      toProto(detection, frame.intrinsics, response->add_detections());
  }
  response->set_compute_ms(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  return grpc::Status::OK;
}

}  // namespace shapesense
