#include "proto_json.h"

#include <google/protobuf/util/json_util.h>

namespace shapesense::console {

std::string toJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string json;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

grpc::Status fromJson(const std::string& json, google::protobuf::Message* message) {
  const auto parsed = google::protobuf::util::JsonStringToMessage(json, message);
  if (parsed.ok()) return grpc::Status::OK;
  return {grpc::INVALID_ARGUMENT, "the request body is not a " + message->GetTypeName() +
                                      " in JSON: " + std::string(parsed.message())};
}

}  // namespace shapesense::console
