#pragma once
// A request whose bytes are not a valid message of the method's request type never reaches a
// handler: gRPC's C++ server answers it itself, with an empty message and INTERNAL (synchronous
// API) or UNIMPLEMENTED (callback API, which the daemon uses). This interceptor turns that answer
// into INVALID_ARGUMENT "request could not be parsed as <type>": the client sent it, and the
// daemon is fine. It changes only calls whose request failed to parse. RpcServer registers it
// before CallLogFactory.

#include <grpcpp/support/server_interceptor.h>

namespace shapesense {

class RequestParseStatusFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;
};

}  // namespace shapesense
