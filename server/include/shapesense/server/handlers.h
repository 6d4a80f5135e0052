#pragma once
// One function per RPC of shapesense.v1.ShapeSense (proto/shapesense/v1/shapesense.proto).
// Each lives in server/src/handlers/<rpc>.cpp with its test in tests/server/<rpc>_test.cpp.
// rpc_server.cpp calls them from gRPC's callback API: unary handlers on a gRPC thread or a
// QueryPool worker, Record on a thread of its own, Watch as a reactor that holds no thread.

#include <functional>

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include "shapesense/server/query_pool.h"
#include "shapesense/server/service_context.h"
#include "shapesense/v1/shapesense.pb.h"

namespace shapesense {

grpc::Status handleGetStatus(const ServiceContext& context, const v1::GetStatusRequest& request,
                             v1::GetStatusResponse* response);

grpc::Status handleListFrames(const ServiceContext& context, const v1::ListFramesRequest& request,
                              v1::ListFramesResponse* response);

grpc::Status handleGetFrame(const ServiceContext& context, const v1::GetFrameRequest& request,
                            v1::GetFrameResponse* response);

/// The Watch stream (a reactor gRPC deletes when the call is done), or one that only finishes
/// with the error: INVALID_ARGUMENT for max_pending > 1024, RESOURCE_EXHAUSTED past the stream
/// limits of context.watch_streams.
grpc::ServerWriteReactor<v1::FrameSummary>* startWatch(const ServiceContext& context,
                                                       grpc::CallbackServerContext* server_context,
                                                       const v1::WatchRequest& request);

grpc::Status handleEstimateBox(const ServiceContext& context, const v1::EstimateBoxRequest& request,
                               v1::EstimateBoxResponse* response);

grpc::Status handleGetDetectedBoxes(const ServiceContext& context,
                                    const v1::GetDetectedBoxesRequest& request,
                                    v1::GetDetectedBoxesResponse* response);

grpc::Status handleGetSegments(const ServiceContext& context, const v1::GetSegmentsRequest& request,
                               v1::GetSegmentsResponse* response);

grpc::Status handleGetPlanes(const ServiceContext& context, const v1::GetPlanesRequest& request,
                             v1::GetPlanesResponse* response);

grpc::Status handleGetBowls(const ServiceContext& context, const v1::GetBowlsRequest& request,
                            v1::GetBowlsResponse* response);

/// The scene model of the frame at T (newest processed for T = 0) with an optional preview.
grpc::Status handleGetScene(const ServiceContext& context, const v1::GetSceneRequest& request,
                            v1::SceneUpdate* response);

/// The WatchScene stream, or one that only finishes with the error: INVALID_ARGUMENT for a
/// rate, full_every_s or preview outside their limits, RESOURCE_EXHAUSTED past the stream
/// limits of context.watch_streams (shared with Watch). Updates are built on `builders` (the
/// query pool) when given, on the publishing thread otherwise.
grpc::ServerWriteReactor<v1::SceneUpdate>* startWatchScene(
    const ServiceContext& context, grpc::CallbackServerContext* server_context,
    const v1::WatchSceneRequest& request, QueryPool* builders);

/// Teaches the object the ROI marks in the frame at T (as EstimateBox mode 4 finds it) and
/// saves it in context.object_models, unless findObject would not find the model in that very
/// frame (its surface from context.scene_surfaces, shared with FindObjects).
grpc::Status handleTeachObject(const ServiceContext& context, const v1::TeachObjectRequest& request,
                               v1::TeachObjectResponse* response);

grpc::Status handleListObjectModels(const ServiceContext& context,
                                    const v1::ListObjectModelsRequest& request,
                                    v1::ListObjectModelsResponse* response);

/// Looks for taught objects in the frame at T; the frame's surface comes from
/// context.scene_surfaces.
grpc::Status handleFindObjects(const ServiceContext& context, const v1::FindObjectsRequest& request,
                               v1::FindObjectsResponse* response);

/// Blocks for the whole recording; `write` sends one progress message and returns false once
/// the client is gone.
grpc::Status handleRecord(const ServiceContext& context,
                          const grpc::ServerContextBase* server_context,
                          const v1::RecordRequest& request,
                          const std::function<bool(const v1::RecordProgress&)>& write);

}  // namespace shapesense
