#pragma once
// How the console answers the page when a call to the daemon fails: the HTTP status of the gRPC
// code (the mapping of google/rpc/code.proto) and a body that keeps the daemon's words.

#include <string>

#include <grpcpp/support/status.h>

#include "shapesense/v1/status_names.h"

namespace shapesense::console {

/// 400 for INVALID_ARGUMENT, OUT_OF_RANGE and FAILED_PRECONDITION, 401, 403, 404, 409 (ABORTED,
/// ALREADY_EXISTS), 429 (RESOURCE_EXHAUSTED), 499 (CANCELLED), 501, 503 (UNAVAILABLE), 504
/// (DEADLINE_EXCEEDED), 500 for the rest.
int httpStatusFor(grpc::StatusCode code);

using v1::statusCodeName;

/// {"code": "<statusCodeName>", "message": "<status.error_message()>"}.
std::string errorBody(const grpc::Status& status);

}  // namespace shapesense::console
