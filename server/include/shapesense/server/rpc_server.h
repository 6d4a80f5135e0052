#pragma once
// The gRPC server: the ShapeSense service plus the standard grpc.health.v1 health service and,
// when asked for, server reflection, listening on one address with the given credentials. Every
// call is logged (CallLogFactory). The service uses gRPC's callback API, so no call holds a
// thread while it waits; heavy queries run on a bounded QueryPool and the limits below answer
// excess load with RESOURCE_EXHAUSTED at once instead of queueing it.

#include <memory>
#include <string>

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server.h>

#include "shapesense/server/query_pool.h"
#include "shapesense/server/service_context.h"
#include "shapesense/server/stream_quota.h"

namespace shapesense {

class ShapeSenseService;
class AccessTokens;

/// The trailing metadata key of gRPC's retry pushback (gRFC A6), in milliseconds.
inline constexpr const char* kRetryPushbackKey = "grpc-retry-pushback-ms";

/// What the server takes on at once (shapesensed --query-workers etc.; README lists them).
struct ServerLimits {
  /// EstimateBox, GetFrame, GetSegments, GetPlanes, GetBowls, GetDetectedBoxes, GetScene,
  /// TeachObject, FindObjects.
  QueryPoolOptions queries;
  /// Unary calls admitted at once (running, or queued for a worker); more: RESOURCE_EXHAUSTED.
  std::size_t max_calls = 128;
  /// Sent with every call refused because the daemon is busy (RESOURCE_EXHAUSTED) as gRPC's
  /// retry pushback, trailing metadata kRetryPushbackKey: how many ms the client should wait
  /// before calling again. 0 = none.
  int busy_pushback_ms = 100;
  /// Watch streams of one client (the peer's address without its port) and of all clients.
  std::size_t max_watch_per_client = 32;
  std::size_t max_watch_streams = 128;
  /// Largest request; every request of the API is a few hundred bytes.
  int max_receive_message_bytes = 64 * 1024;
  /// HTTP/2 streams (calls) one connection may have open; more wait in the client.
  int max_streams_per_connection = 100;
  /// The server pings a connection idle this long, and drops it when the ping is not answered
  /// within the timeout: a vanished client's streams end instead of lingering.
  int keepalive_ms = 30'000;
  int keepalive_timeout_ms = 10'000;
  /// Nice value of gRPC's own threads (0..19), which receive every call, refuse the excess and
  /// write streams: a flood of calls then takes time from them, not from the detector thread.
  /// Applied by Daemon, which starts gRPC from a thread at this nice value. Default 5.
  int grpc_nice = 5;
};

struct RpcServerOptions {
  /// Null: plain (InsecureServerCredentials).
  std::shared_ptr<grpc::ServerCredentials> credentials;
  /// Names clients in the call log; null when the daemon takes no tokens.
  std::shared_ptr<const AccessTokens> tokens;
  /// Serve grpc.reflection.v1alpha (lists the whole API to anyone who may call).
  bool reflection = false;
  ServerLimits limits;
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

  /// Where heavy queries run; tests occupy it to see what a full pool answers.
  QueryPool& queryPool() { return *queries_; }

 private:
  std::atomic<bool> shutting_down_{false};
  SummaryHub* hub_ = nullptr;
  // Outlive the server: calls in flight at shutdown still use them.
  std::unique_ptr<QueryPool> queries_;
  std::unique_ptr<StreamQuota> watch_streams_;
  std::unique_ptr<ShapeSenseService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace shapesense
