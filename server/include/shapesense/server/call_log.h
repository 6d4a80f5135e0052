#pragma once
// One log line per RPC: method, peer, client (the token's NAME when tokens are on), status and
// duration; at info for Record (it writes on the daemon's machine), at debug for the rest.

#include <memory>

#include <grpcpp/support/server_interceptor.h>

#include "shapesense/server/access_tokens.h"

namespace shapesense {

class CallLogFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  /// `tokens` names the clients in the log; null when the daemon takes no tokens.
  explicit CallLogFactory(std::shared_ptr<const AccessTokens> tokens = nullptr)
      : tokens_(std::move(tokens)) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;

 private:
  std::shared_ptr<const AccessTokens> tokens_;
};

}  // namespace shapesense
