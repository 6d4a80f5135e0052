#pragma once
// One log line per RPC: method, peer, client (the token's NAME when tokens are on), status and
// duration; at info for Record (it writes on the daemon's machine), at debug for the rest. The
// durations of unary calls also go to the daemon's CallLatencies, for GetStatus.

#include <memory>

#include <grpcpp/support/server_interceptor.h>

#include "shapesense/server/access_tokens.h"
#include "shapesense/server/call_latencies.h"

namespace shapesense {

class CallLogFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  /// `tokens` names the clients in the log; null when the daemon takes no tokens. `latencies`
  /// receives every unary call's duration; may be null.
  explicit CallLogFactory(std::shared_ptr<const AccessTokens> tokens = nullptr,
                          std::shared_ptr<CallLatencies> latencies = nullptr)
      : tokens_(std::move(tokens)), latencies_(std::move(latencies)) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;

 private:
  std::shared_ptr<const AccessTokens> tokens_;
  std::shared_ptr<CallLatencies> latencies_;
};

}  // namespace shapesense
