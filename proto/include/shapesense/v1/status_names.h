#pragma once
// Names of gRPC status codes as the API documents them, for clients that print or forward an
// error (the CLI, the console, the load tool).

#include <string>

#include <grpcpp/support/status.h>

namespace shapesense::v1 {

/// "OUT_OF_RANGE", "UNAVAILABLE", ...; "code N" for a value gRPC does not define.
std::string statusCodeName(grpc::StatusCode code);

}  // namespace shapesense::v1
