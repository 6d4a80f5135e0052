#include "shapesense/server/latency_tracker.h"

#include <algorithm>
#include <cmath>

namespace shapesense {

void LatencyTracker::record(const std::string& stage, double ms) {
  std::lock_guard lock(mutex_);
  auto [it, inserted] = windows_.try_emplace(stage);
  if (inserted) order_.push_back(stage);
  Window& w = it->second;
  if (w.samples.size() < kWindow) {
    w.samples.push_back(ms);
  } else {
    w.samples[w.next] = ms;
  }
  w.next = (w.next + 1) % kWindow;
  ++w.runs;
  w.last = ms;
}

std::vector<LatencySummary> LatencyTracker::summaries() const {
  std::lock_guard lock(mutex_);
  std::vector<LatencySummary> out;
  for (const auto& stage : order_) {
    const Window& w = windows_.at(stage);
    std::vector<double> sorted = w.samples;
    std::sort(sorted.begin(), sorted.end());
    auto quantile = [&](double q) {
      const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
      return sorted[std::min(sorted.size() - 1, i == 0 ? 0 : i - 1)];
    };
    out.push_back({stage, w.runs, w.last, quantile(0.5), quantile(0.95)});
  }
  return out;
}

}  // namespace shapesense
