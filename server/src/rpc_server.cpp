#include "shapesense/server/rpc_server.h"

#include <condition_variable>
#include <mutex>
#include <thread>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server_builder.h>

#include "shapesense/server/access_tokens.h"
#include "shapesense/server/call_log.h"
#include "shapesense/server/handlers.h"
#include "shapesense/server/request_parse_status.h"
#include "shapesense/v1/shapesense.grpc.pb.h"

namespace shapesense {
namespace {

/// Record as a stream: the handler blocks for the whole recording (it drains the frame queue
/// into files), so it runs on a thread of its own (one recording at a time) and writes through
/// a write that waits for its completion.
class RecordReactor final : public grpc::ServerWriteReactor<v1::RecordProgress> {
 public:
  RecordReactor(const ServiceContext& context, grpc::CallbackServerContext* server_context,
                const v1::RecordRequest* request) {
    std::thread([this, &context, server_context, request] {
      const grpc::Status status =
          handleRecord(context, server_context, *request,
                       [this](const v1::RecordProgress& message) { return write(message); });
      Finish(status);  // OnDone deletes this later, on a gRPC thread; nothing here touches it
    }).detach();
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard lock(mutex_);
      write_ok_ = ok;
      write_done_ = true;
    }
    written_.notify_one();
  }
  void OnDone() override { delete this; }

 private:
  bool write(const v1::RecordProgress& message) {
    std::unique_lock lock(mutex_);
    write_done_ = false;
    StartWrite(&message);
    written_.wait(lock, [this] { return write_done_; });
    return write_ok_;
  }

  std::mutex mutex_;
  std::condition_variable written_;
  bool write_done_ = false;
  bool write_ok_ = false;
};

}  // namespace

/// Routes each RPC to its handler: the cheap ones on the gRPC thread that received the call,
/// the heavy ones on the QueryPool, each unary call counted against ServerLimits::max_calls.
class ShapeSenseService final : public v1::ShapeSense::CallbackService {
 public:
  ShapeSenseService(ServiceContext context, QueryPool& queries, std::size_t max_calls,
                    int busy_pushback_ms)
      : context_(std::move(context)),
        queries_(queries),
        max_calls_(max_calls),
        busy_pushback_ms_(busy_pushback_ms) {}

  const ServiceContext& context() const { return context_; }

  grpc::ServerUnaryReactor* GetStatus(grpc::CallbackServerContext* call,
                                      const v1::GetStatusRequest* request,
                                      v1::GetStatusResponse* response) override {
    return here(call, [=, this] { return handleGetStatus(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* ListFrames(grpc::CallbackServerContext* call,
                                       const v1::ListFramesRequest* request,
                                       v1::ListFramesResponse* response) override {
    return here(call, [=, this] { return handleListFrames(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* GetFrame(grpc::CallbackServerContext* call,
                                     const v1::GetFrameRequest* request,
                                     v1::GetFrameResponse* response) override {
    return onPool(call, [=, this] { return handleGetFrame(context_, *request, response); });
  }
  grpc::ServerWriteReactor<v1::FrameSummary>* Watch(grpc::CallbackServerContext* call,
                                                    const v1::WatchRequest* request) override {
    return startWatch(context_, call, *request);
  }
  grpc::ServerUnaryReactor* EstimateBox(grpc::CallbackServerContext* call,
                                        const v1::EstimateBoxRequest* request,
                                        v1::EstimateBoxResponse* response) override {
    return onPool(call, [=, this] { return handleEstimateBox(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* GetDetectedBoxes(grpc::CallbackServerContext* call,
                                             const v1::GetDetectedBoxesRequest* request,
                                             v1::GetDetectedBoxesResponse* response) override {
    return onPool(call, [=, this] { return handleGetDetectedBoxes(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* GetSegments(grpc::CallbackServerContext* call,
                                        const v1::GetSegmentsRequest* request,
                                        v1::GetSegmentsResponse* response) override {
    return onPool(call, [=, this] { return handleGetSegments(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* GetPlanes(grpc::CallbackServerContext* call,
                                      const v1::GetPlanesRequest* request,
                                      v1::GetPlanesResponse* response) override {
    return onPool(call, [=, this] { return handleGetPlanes(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* GetBowls(grpc::CallbackServerContext* call,
                                     const v1::GetBowlsRequest* request,
                                     v1::GetBowlsResponse* response) override {
    return onPool(call, [=, this] { return handleGetBowls(context_, *request, response); });
  }
  grpc::ServerWriteReactor<v1::RecordProgress>* Record(grpc::CallbackServerContext* call,
                                                       const v1::RecordRequest* request) override {
    return new RecordReactor(context_, call, request);
  }
  grpc::ServerUnaryReactor* GetScene(grpc::CallbackServerContext* call,
                                     const v1::GetSceneRequest* request,
                                     v1::SceneUpdate* response) override {
    return onPool(call, [=, this] { return handleGetScene(context_, *request, response); });
  }
  grpc::ServerWriteReactor<v1::SceneUpdate>* WatchScene(
      grpc::CallbackServerContext* call, const v1::WatchSceneRequest* request) override {
    return startWatchScene(context_, call, *request, &queries_);
  }
  grpc::ServerUnaryReactor* TeachObject(grpc::CallbackServerContext* call,
                                        const v1::TeachObjectRequest* request,
                                        v1::TeachObjectResponse* response) override {
    return onPool(call, [=, this] { return handleTeachObject(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* ListObjectModels(grpc::CallbackServerContext* call,
                                             const v1::ListObjectModelsRequest* request,
                                             v1::ListObjectModelsResponse* response) override {
    return here(call, [=, this] { return handleListObjectModels(context_, *request, response); });
  }
  grpc::ServerUnaryReactor* FindObjects(grpc::CallbackServerContext* call,
                                        const v1::FindObjectsRequest* request,
                                        v1::FindObjectsResponse* response) override {
    return onPool(call, [=, this] { return handleFindObjects(context_, *request, response); });
  }

 private:
  /// Admits one more unary call, or refuses it.
  bool admit(grpc::CallbackServerContext* call, grpc::ServerUnaryReactor* reactor) {
    if (in_flight_.fetch_add(1) < max_calls_) return true;
    in_flight_.fetch_sub(1);
    advisePushback(call);
    reactor->Finish({grpc::StatusCode::RESOURCE_EXHAUSTED,
                     "the daemon is answering " + std::to_string(max_calls_) +
                         " calls already (shapesensed --max-calls); retry later"});
    return false;
  }
  void finish(grpc::ServerUnaryReactor* reactor, const grpc::Status& status) {
    in_flight_.fetch_sub(1);
    reactor->Finish(status);
  }
  /// Finishes an admitted call the daemon is too busy for, telling the client when to call again.
  void refuseBusy(grpc::CallbackServerContext* call, grpc::ServerUnaryReactor* reactor,
                  const std::string& why) {
    advisePushback(call);
    finish(reactor, {grpc::StatusCode::RESOURCE_EXHAUSTED, why});
  }
  /// gRPC's retry pushback (gRFC A6): clients whose retry policy or own code honours it come
  /// back after that long, instead of turning a flood into refusals that take the answers' CPU.
  void advisePushback(grpc::CallbackServerContext* call) const {
    if (busy_pushback_ms_ > 0)
      call->AddTrailingMetadata(kRetryPushbackKey, std::to_string(busy_pushback_ms_));
  }

  /// A cheap call (a copy of counters or of the cache's index): answered on this gRPC thread.
  template <class Handler>
  grpc::ServerUnaryReactor* here(grpc::CallbackServerContext* call, Handler handler) {
    auto* reactor = call->DefaultReactor();
    if (admit(call, reactor)) finish(reactor, handler());
    return reactor;
  }

  /// A heavy call: queued for a QueryPool worker, or refused at once when the queue is full.
  template <class Handler>
  grpc::ServerUnaryReactor* onPool(grpc::CallbackServerContext* call, Handler handler) {
    auto* reactor = call->DefaultReactor();
    if (!admit(call, reactor)) return reactor;
    const bool queued = queries_.trySubmit([this, call, reactor, handler](bool run) {
      if (!run) {
        refuseBusy(call, reactor,
                   "the daemon's query workers are busy: this call waited " +
                       std::to_string(queries_.maxWait().count()) +
                       " ms for one (shapesensed --query-max-wait-ms); retry later");
      } else if (call->IsCancelled()) {
        // A client that gave up while the call waited does not get the work done for nothing.
        finish(reactor, {grpc::StatusCode::CANCELLED, "cancelled while queued"});
      } else {
        finish(reactor, handler());
      }
    });
    if (!queued) {
      refuseBusy(call, reactor,
                 "the daemon's query workers are busy and " + std::to_string(queries_.capacity()) +
                     " queries wait already (shapesensed --query-workers, --query-queue); retry "
                     "later");
    }
    return reactor;
  }

  ServiceContext context_;
  QueryPool& queries_;
  const std::size_t max_calls_;
  const int busy_pushback_ms_;
  std::atomic<std::size_t> in_flight_{0};
};

namespace {

/// Serves reflection on one server, or not. Linking grpc++_reflection registers its plugin with
/// every ServerBuilder of the process (a static initializer), so "not" means taking it out.
class ReflectionOption final : public grpc::ServerBuilderOption {
 public:
  explicit ReflectionOption(bool enabled) : enabled_(enabled) {}
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    const std::string name = grpc::reflection::ProtoServerReflectionPlugin().name();
    std::erase_if(*plugins, [&name](const auto& plugin) { return plugin->name() == name; });
    if (enabled_)
      plugins->push_back(std::make_unique<grpc::reflection::ProtoServerReflectionPlugin>());
  }

 private:
  bool enabled_;
};

}  // namespace

RpcServer::RpcServer(const std::string& listen_address, ServiceContext context,
                     RpcServerOptions options) {
  const ServerLimits& limits = options.limits;
  context.shutting_down = &shutting_down_;
  hub_ = &context.hub;
  queries_ = std::make_unique<QueryPool>(limits.queries);
  watch_streams_ =
      std::make_unique<StreamQuota>(limits.max_watch_per_client, limits.max_watch_streams);
  context.watch_streams = watch_streams_.get();
  service_ = std::make_unique<ShapeSenseService>(std::move(context), *queries_, limits.max_calls,
                                                 limits.busy_pushback_ms);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  builder.SetMaxReceiveMessageSize(limits.max_receive_message_bytes);
  builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS, limits.max_streams_per_connection);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, limits.keepalive_ms);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, limits.keepalive_timeout_ms);
  // Keepalive pings go out on connections whose only call is a quiet stream, too.
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  // Clients may keep their connections alive the same way, but not ping more often than this.
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10'000);
  builder.SetOption(std::make_unique<ReflectionOption>(options.reflection));
  // gRPC enables SO_REUSEPORT by default, which lets a second daemon bind the same port and
  // share its clients; one address must mean one daemon.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(
      listen_address, options.credentials ? options.credentials : grpc::InsecureServerCredentials(),
      &port_);
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<RequestParseStatusFactory>());
  interceptors.push_back(
      std::make_unique<CallLogFactory>(options.tokens, service_->context().call_latencies));
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  builder.RegisterService(service_.get());
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    throw std::runtime_error(
        "cannot listen on " + listen_address +
        (options.credentials
             ? " (address in use or not valid, or --tls-key is not the key of --tls-cert)"
             : " (address in use or not valid; choose another with --listen)"));
  }
}

RpcServer::~RpcServer() { shutdown(); }

void RpcServer::shutdown(std::chrono::milliseconds deadline) {
  if (!server_ || shutting_down_.exchange(true)) return;
  server_->GetHealthCheckService()->Shutdown();
  hub_->closeAll();  // open Watch streams finish now instead of at the deadline
  server_->Shutdown(std::chrono::system_clock::now() + deadline);
  queries_->stop();
}

void RpcServer::wait() {
  if (server_) server_->Wait();
}

}  // namespace shapesense
