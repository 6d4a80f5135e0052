#include "shapesense/server/call_log.h"

#include <chrono>
#include <string>

#include <grpcpp/server_context.h>
#include <spdlog/spdlog.h>

#include "shapesense/server/transport_security.h"

namespace shapesense {
namespace {

using grpc::experimental::InterceptionHookPoints;

const char* codeName(grpc::StatusCode code) {
  static constexpr const char* kNames[] = {"OK",
                                           "CANCELLED",
                                           "UNKNOWN",
                                           "INVALID_ARGUMENT",
                                           "DEADLINE_EXCEEDED",
                                           "NOT_FOUND",
                                           "ALREADY_EXISTS",
                                           "PERMISSION_DENIED",
                                           "RESOURCE_EXHAUSTED",
                                           "FAILED_PRECONDITION",
                                           "ABORTED",
                                           "OUT_OF_RANGE",
                                           "UNIMPLEMENTED",
                                           "INTERNAL",
                                           "UNAVAILABLE",
                                           "DATA_LOSS",
                                           "UNAUTHENTICATED"};
  const auto index = static_cast<std::size_t>(code);
  return index < std::size(kNames) ? kNames[index] : "?";
}

class CallLogInterceptor final : public grpc::experimental::Interceptor {
 public:
  CallLogInterceptor(grpc::experimental::ServerRpcInfo* info, const AccessTokens* tokens,
                     CallLatencies* latencies)
      : info_(info),
        tokens_(tokens),
        latencies_(latencies),
        start_(std::chrono::steady_clock::now()) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      const grpc::Status status = methods->GetSendStatus();
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
              .count();
      const std::string method = info_->method() ? info_->method() : "?";
      if (latencies_ && info_->type() == grpc::experimental::ServerRpcInfo::Type::UNARY) {
        latencies_->record(method, status.error_code(), ms);
      }
      log(method, status, ms);
    }
    methods->Proceed();
  }

 private:
  void log(const std::string& method, const grpc::Status& status, double ms) const {
    const auto level =
        method == "/shapesense.v1.ShapeSense/Record" ? spdlog::level::info : spdlog::level::debug;
    if (!spdlog::should_log(level)) return;
    grpc::ServerContextBase* context = info_->server_context();
    if (status.ok()) {
      spdlog::log(level, "rpc {} from {}{}: OK in {:.1f} ms", method, context->peer(),
                  client(*context), ms);
    } else {
      spdlog::log(level, "rpc {} from {}{}: {} ({}) in {:.1f} ms", method, context->peer(),
                  client(*context), codeName(status.error_code()), status.error_message(), ms);
    }
  }

  std::string client(const grpc::ServerContextBase& context) const {
    if (!tokens_) return "";
    const auto& metadata = context.client_metadata();
    const auto header = metadata.find("authorization");
    if (header == metadata.end()) return "";
    const auto grant =
        tokens_->find(bearerToken(std::string_view(header->second.data(), header->second.size())));
    return grant ? " (" + grant->name + ")" : "";
  }

  grpc::experimental::ServerRpcInfo* info_;
  const AccessTokens* tokens_;
  CallLatencies* latencies_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

grpc::experimental::Interceptor* CallLogFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  return new CallLogInterceptor(info, tokens_.get(), latencies_.get());
}

}  // namespace shapesense
