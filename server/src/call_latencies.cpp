#include "shapesense/server/call_latencies.h"

#include <algorithm>

namespace shapesense {

void CallLatencies::record(const std::string& method, grpc::StatusCode code, double ms) {
  const auto slash = method.rfind('/');
  const std::string_view name = slash == std::string::npos
                                    ? std::string_view(method)
                                    : std::string_view(method).substr(slash + 1);
  std::lock_guard lock(mutex_);
  auto found = methods_.find(name);
  if (found == methods_.end()) {
    found = methods_.emplace(std::string(name), MethodLatency{}).first;
    found->second.method = std::string(name);
  }
  MethodLatency& entry = found->second;
  if (code == grpc::StatusCode::RESOURCE_EXHAUSTED) {
    ++entry.refused;
    return;
  }
  if (code != grpc::StatusCode::OK) {
    ++entry.failed;
    return;
  }
  ++entry.answered;
  const auto& bounds = MethodLatency::kBucketUpperMs;
  const auto bucket = std::lower_bound(bounds.begin(), bounds.end(), ms) - bounds.begin();
  ++entry.answered_by_bucket[static_cast<std::size_t>(bucket)];
}

std::vector<MethodLatency> CallLatencies::snapshot() const {
  std::lock_guard lock(mutex_);
  std::vector<MethodLatency> out;
  out.reserve(methods_.size());
  for (const auto& [name, entry] : methods_) out.push_back(entry);
  return out;
}

}  // namespace shapesense
