#pragma once
// The gRPC server: the ShapeSense service plus the standard grpc.health.v1 health service and,
// when asked for, server reflection, listening on one address with the given credentials. Every
// call is logged (CallLogFactory).

#include <memory>
#include <string>

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server.h>

#include "shapesense/server/service_context.h"

namespace shapesense {

class ShapeSenseService;
class AccessTokens;

struct RpcServerOptions {
  /// Null: plain (InsecureServerCredentials).
  std::shared_ptr<grpc::ServerCredentials> credentials;
  /// Names clients in the call log; null when the daemon takes no tokens.
  std::shared_ptr<const AccessTokens> tokens;
  /// Serve grpc.reflection.v1alpha (lists the whole API to anyone who may call).
  bool reflection = false;
};

class RpcServer {
 public:
  /// Starts listening; throws std::runtime_error naming the address when it cannot bind.
  /// "127.0.0.1:0" picks a free port (see port()).
  RpcServer(const std::string& listen_address, ServiceContext context,
            RpcServerOptions options = {});
  ~RpcServer();

  /// The bound port.
  int port() const { return port_; }
  /// Ends open streams and stops serving; waits at most `deadline` for calls in flight.
  void shutdown(std::chrono::milliseconds deadline = std::chrono::milliseconds(1500));
  void wait();

 private:
  std::atomic<bool> shutting_down_{false};
  std::unique_ptr<ShapeSenseService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace shapesense
