#include "connection.h"

#include <google/protobuf/util/json_util.h>

namespace shapesense::cli {

std::string statusCodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::OK:
      return "OK";
    case grpc::CANCELLED:
      return "CANCELLED";
    case grpc::UNKNOWN:
      return "UNKNOWN";
    case grpc::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::ABORTED:
      return "ABORTED";
    case grpc::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::INTERNAL:
      return "INTERNAL";
    case grpc::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::DATA_LOSS:
      return "DATA_LOSS";
    case grpc::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    default:
      return "code " + std::to_string(static_cast<int>(code));
  }
}

RpcError::RpcError(const grpc::Status& status)
    : std::runtime_error(statusCodeName(status.error_code()) + ": " + status.error_message()),
      code_(status.error_code()) {}

Connection::Connection(const GlobalOptions& options)
    : options_(options),
      stub_(v1::ShapeSense::NewStub(
          grpc::CreateChannel(options.server, grpc::InsecureChannelCredentials()))) {}

std::unique_ptr<grpc::ClientContext> Connection::context() const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<long>(options_.timeout_s * 1000)));
  return context;
}

std::unique_ptr<grpc::ClientContext> Connection::streamContext() {
  return std::make_unique<grpc::ClientContext>();
}

void Connection::check(const grpc::Status& status) {
  if (!status.ok()) throw RpcError(status);
}

std::string toJson(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

std::int64_t Connection::newestProcessedFrame() {
  v1::ListFramesResponse frames;
  check(stub().ListFrames(context().get(), {}, &frames));
  for (auto it = frames.frames().rbegin(); it != frames.frames().rend(); ++it) {
    if (it->processed()) return it->timestamp_ns();
  }
  return 0;
}

}  // namespace shapesense::cli
