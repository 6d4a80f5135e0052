#pragma once
// A request whose bytes are not a valid message of the method's request type never reaches a
// handler: gRPC's C++ server answers it itself, with INTERNAL and an empty message (the protobuf
// parser's InitializationErrorString, empty for proto3). This interceptor turns that answer into
// INVALID_ARGUMENT "request could not be parsed as <type>": the client sent it, and the daemon is
// fine. It changes only calls whose request failed to parse. Register it before CallLogFactory,
// so that the log line can show the status the client gets (the order is not tested yet: RpcServer
// does not register it at this commit).

#include <grpcpp/support/server_interceptor.h>

namespace shapesense {

class RequestParseStatusFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;
};

}  // namespace shapesense
