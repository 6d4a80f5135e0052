#include "shapesense/server/handlers.h"
#include "shapesense/server/proto_convert.h"

namespace shapesense {

grpc::Status handleListObjectModels(const ServiceContext& context,
                                    const v1::ListObjectModelsRequest& /*request*/,
                                    v1::ListObjectModelsResponse* response) {
  ObjectModelStore* store = nullptr;
  if (auto status = objectModelsOf(context, store); !status.ok()) return status;
  for (const auto& stored : store->list()) toProto(stored, response->add_models());
  response->set_max_models(static_cast<std::uint32_t>(store->maxModels()));
  return grpc::Status::OK;
}

}  // namespace shapesense
