#pragma once
// The API's messages in and out of JSON with protobuf's own mapping: proto field names, every
// field printed (so the page never guesses a default), 64-bit integers as strings.

#include <string>

#include <google/protobuf/message.h>
#include <grpcpp/support/status.h>

namespace shapesense::console {

std::string toJson(const google::protobuf::Message& message);

/// Fills `message` from `json`; INVALID_ARGUMENT naming the message type when it does not parse.
grpc::Status fromJson(const std::string& json, google::protobuf::Message* message);

}  // namespace shapesense::console
