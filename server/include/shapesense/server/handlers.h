#pragma once
// One function per RPC of shapesense.v1.ShapeSense (proto/shapesense/v1/shapesense.proto).
// Each lives in server/src/handlers/<rpc>.cpp with its test in tests/server/<rpc>_test.cpp.

#include <grpcpp/server_context.h>
#include <grpcpp/support/sync_stream.h>

#include "shapesense/server/service_context.h"
#include "shapesense/v1/shapesense.pb.h"

namespace shapesense {

grpc::Status handleGetStatus(const ServiceContext& context, const v1::GetStatusRequest& request,
                             v1::GetStatusResponse* response);

grpc::Status handleListFrames(const ServiceContext& context, const v1::ListFramesRequest& request,
                              v1::ListFramesResponse* response);

grpc::Status handleGetFrame(const ServiceContext& context, const v1::GetFrameRequest& request,
                            v1::GetFrameResponse* response);

grpc::Status handleWatch(const ServiceContext& context, grpc::ServerContext* server_context,
                         const v1::WatchRequest& request,
                         grpc::ServerWriter<v1::FrameSummary>* writer);

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

grpc::Status handleRecord(const ServiceContext& context, grpc::ServerContext* server_context,
                          const v1::RecordRequest& request,
                          grpc::ServerWriter<v1::RecordProgress>* writer);

}  // namespace shapesense
