#pragma once
// How long the daemon took to answer its unary calls, by method, since it started: from the
// call's arrival to its status being sent, so queueing for a query worker counts, and the
// network and the client do not. Kept as counts per latency bucket (as Prometheus histograms
// are), so a client that reads them at the start and the end of a run gets that run's
// distribution by subtracting, whatever happened in between. GetStatus serves them.

#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <grpcpp/support/status.h>

namespace shapesense {

struct MethodLatency {
  /// Upper bounds of the buckets in ms; the last bucket (one more count) takes the rest.
  static constexpr std::array<double, 14> kBucketUpperMs = {0.25, 0.5, 1,  2,  3,  5,   7.5,
                                                            10,   15,  20, 30, 50, 100, 250};
  std::string method;          ///< "EstimateBox", ...
  std::uint64_t answered = 0;  ///< calls that ended OK
  std::uint64_t refused = 0;   ///< RESOURCE_EXHAUSTED: busy, or a limit reached
  std::uint64_t failed = 0;    ///< any other status
  std::vector<std::uint64_t> answered_by_bucket =
      std::vector<std::uint64_t>(kBucketUpperMs.size() + 1);  ///< answered calls' latencies
};

class CallLatencies {
 public:
  /// `method` as gRPC names it ("/shapesense.v1.ShapeSense/EstimateBox") or bare.
  void record(const std::string& method, grpc::StatusCode code, double ms);
  /// Every method seen, by name.
  std::vector<MethodLatency> snapshot() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, MethodLatency, std::less<>> methods_;
};

}  // namespace shapesense
