#pragma once
// Rolling latency statistics per pipeline stage, for GetStatus.

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace shapesense {

struct LatencySummary {
  std::string stage;
  std::uint64_t runs = 0;
  double last_ms = 0;
  double median_ms = 0;  ///< over the window
  double p95_ms = 0;     ///< over the window
};

class LatencyTracker {
 public:
  static constexpr std::size_t kWindow = 256;

  void record(const std::string& stage, double ms);
  /// One summary per stage seen, in order of first appearance.
  std::vector<LatencySummary> summaries() const;

 private:
  struct Window {
    std::vector<double> samples;  // ring of the last kWindow samples
    std::size_t next = 0;
    std::uint64_t runs = 0;
    double last = 0;
  };
  mutable std::mutex mutex_;
  std::vector<std::string> order_;
  std::map<std::string, Window> windows_;
};

}  // namespace shapesense
