#include "shapesense/server/handlers.h"
#include "shapesense/server/scene_update.h"

namespace shapesense {

grpc::Status handleGetScene(const ServiceContext& context, const v1::GetSceneRequest& request,
                            v1::SceneUpdate* response) {
  PreviewOptions preview;
  if (auto status = parsePreview(request.preview(), preview); !status.ok()) return status;
  CachedFrame entry;
  if (auto status = lookupSceneFrame(context.cache, request.at_ns(), entry); !status.ok()) {
    return status;
  }
  if (auto status = fillScene(entry, context.session_id, *response); !status.ok()) return status;
  addPreview(*entry.frame, preview, *response);
  return grpc::Status::OK;
}

}  // namespace shapesense
