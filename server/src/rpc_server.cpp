#include "shapesense/server/rpc_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server_builder.h>

#include "shapesense/server/access_tokens.h"
#include "shapesense/server/call_log.h"
#include "shapesense/server/handlers.h"
#include "shapesense/v1/shapesense.grpc.pb.h"

namespace shapesense {

/// Routes each RPC to its handler.
class ShapeSenseService final : public v1::ShapeSense::Service {
 public:
  explicit ShapeSenseService(ServiceContext context) : context_(std::move(context)) {}

  grpc::Status GetStatus(grpc::ServerContext*, const v1::GetStatusRequest* request,
                         v1::GetStatusResponse* response) override {
    return handleGetStatus(context_, *request, response);
  }
  grpc::Status ListFrames(grpc::ServerContext*, const v1::ListFramesRequest* request,
                          v1::ListFramesResponse* response) override {
    return handleListFrames(context_, *request, response);
  }
  grpc::Status GetFrame(grpc::ServerContext*, const v1::GetFrameRequest* request,
                        v1::GetFrameResponse* response) override {
    return handleGetFrame(context_, *request, response);
  }
  grpc::Status Watch(grpc::ServerContext* server_context, const v1::WatchRequest* request,
                     grpc::ServerWriter<v1::FrameSummary>* writer) override {
    return handleWatch(context_, server_context, *request, writer);
  }
  grpc::Status EstimateBox(grpc::ServerContext*, const v1::EstimateBoxRequest* request,
                           v1::EstimateBoxResponse* response) override {
    return handleEstimateBox(context_, *request, response);
  }
  grpc::Status GetDetectedBoxes(grpc::ServerContext*, const v1::GetDetectedBoxesRequest* request,
                                v1::GetDetectedBoxesResponse* response) override {
    return handleGetDetectedBoxes(context_, *request, response);
  }
  grpc::Status GetSegments(grpc::ServerContext*, const v1::GetSegmentsRequest* request,
                           v1::GetSegmentsResponse* response) override {
    return handleGetSegments(context_, *request, response);
  }
  grpc::Status GetPlanes(grpc::ServerContext*, const v1::GetPlanesRequest* request,
                         v1::GetPlanesResponse* response) override {
    return handleGetPlanes(context_, *request, response);
  }
  grpc::Status GetBowls(grpc::ServerContext*, const v1::GetBowlsRequest* request,
                        v1::GetBowlsResponse* response) override {
    return handleGetBowls(context_, *request, response);
  }
  grpc::Status Record(grpc::ServerContext* server_context, const v1::RecordRequest* request,
                      grpc::ServerWriter<v1::RecordProgress>* writer) override {
    return handleRecord(context_, server_context, *request, writer);
  }

 private:
  ServiceContext context_;
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
  context.shutting_down = &shutting_down_;
  service_ = std::make_unique<ShapeSenseService>(std::move(context));
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  builder.SetOption(std::make_unique<ReflectionOption>(options.reflection));
  // gRPC enables SO_REUSEPORT by default, which lets a second daemon bind the same port and
  // share its clients; one address must mean one daemon.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(
      listen_address, options.credentials ? options.credentials : grpc::InsecureServerCredentials(),
      &port_);
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<CallLogFactory>(options.tokens));
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
  server_->Shutdown(std::chrono::system_clock::now() + deadline);
}

void RpcServer::wait() {
  if (server_) server_->Wait();
}

}  // namespace shapesense
