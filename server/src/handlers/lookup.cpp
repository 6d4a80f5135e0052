#include "shapesense/server/service_context.h"

#include <random>

#include <fmt/format.h>

namespace shapesense {

std::string newSessionId() {
  std::random_device entropy;
  const std::uint64_t high = (static_cast<std::uint64_t>(entropy()) << 32) | entropy();
  const std::uint64_t low = (static_cast<std::uint64_t>(entropy()) << 32) | entropy();
  return fmt::format("{:016x}{:016x}", high, low);
}

grpc::Status lookupFrame(const FrameCache& cache, std::int64_t at_ns, CachedFrame& out) {
  if (at_ns < 0) {
    return {
        grpc::StatusCode::INVALID_ARGUMENT,
        "at_ns must be a capture time in nanoseconds since the epoch, or 0 for the newest frame"};
  }
  auto found = cache.at(at_ns);
  if (auto* error = std::get_if<LookupError>(&found)) {
    const auto code = error->kind == LookupError::Kind::kEmpty ? grpc::StatusCode::UNAVAILABLE
                                                               : grpc::StatusCode::OUT_OF_RANGE;
    return {code, error->message};
  }
  out = std::get<CachedFrame>(std::move(found));
  return grpc::Status::OK;
}

grpc::Status lookupProcessedFrame(const FrameCache& cache, std::int64_t at_ns, CachedFrame& out) {
  if (auto status = lookupFrame(cache, at_ns, out); !status.ok()) return status;
  if (!out.results) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the detectors have not processed this frame (it was skipped or is still being "
            "processed); ask for a neighbouring frame"};
  }
  return grpc::Status::OK;
}

grpc::Status objectModelsOf(const ServiceContext& context, ObjectModelStore*& out) {
  out = context.object_models;
  if (out) return grpc::Status::OK;
  return {grpc::StatusCode::FAILED_PRECONDITION,
          "this daemon keeps no taught objects (it runs without an object models folder)"};
}

}  // namespace shapesense
