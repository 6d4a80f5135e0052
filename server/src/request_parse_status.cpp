#include "shapesense/server/request_parse_status.h"

#include <string>

namespace shapesense {
namespace {

using grpc::experimental::InterceptionHookPoints;

class RequestParseStatus final : public grpc::experimental::Interceptor {
 public:
  explicit RequestParseStatus(grpc::experimental::ServerRpcInfo* info) : info_(info) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    // The server hands interceptors no message when deserialising the request failed; a
    // client-streaming method (none here) would see that at its end too, so only unary and
    // server-streaming calls are judged.
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE) &&
        methods->GetRecvMessage() == nullptr && !clientStreams()) {
      unparsed_ = true;
    }
    if (unparsed_ && methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      // gRPC's own answer to unparsable bytes: INTERNAL from the synchronous API,
      // UNIMPLEMENTED from the callback API; both with an empty message.
      const grpc::StatusCode sent = methods->GetSendStatus().error_code();
      if (sent == grpc::StatusCode::INTERNAL || sent == grpc::StatusCode::UNIMPLEMENTED) {
        methods->ModifySendStatus(grpc::Status(
            grpc::StatusCode::INVALID_ARGUMENT,
            "request could not be parsed as " + requestType() + " (malformed protobuf bytes)"));
      }
    }
    methods->Proceed();
  }

 private:
  bool clientStreams() const {
    const auto type = info_->type();
    return type == grpc::experimental::ServerRpcInfo::Type::CLIENT_STREAMING ||
           type == grpc::experimental::ServerRpcInfo::Type::BIDI_STREAMING;
  }

  /// "/shapesense.v1.ShapeSense/GetFrame" -> "the GetFrame request".
  std::string requestType() const {
    const std::string method = info_->method() ? info_->method() : "";
    const auto slash = method.rfind('/');
    return "the " + (slash == std::string::npos ? method : method.substr(slash + 1)) + " request";
  }

  grpc::experimental::ServerRpcInfo* info_;
  bool unparsed_ = false;
};

}  // namespace

grpc::experimental::Interceptor* RequestParseStatusFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  return new RequestParseStatus(info);
}

}  // namespace shapesense
