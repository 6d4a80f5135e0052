#pragma once
// What the detector pipeline computed from one frame. Each detector fills its own member;
// a member a detector did not produce stays empty.

#include <map>
#include <optional>
#include <string>

namespace shapesense {

/// The trivial per-frame statistic computed for every frame.
struct DepthStatistics {
  double valid_fraction = 0.0;
  double min_m = 0.0;
  double median_m = 0.0;
  double max_m = 0.0;
};

struct FrameResults {
  std::optional<DepthStatistics> depth_stats;
  /// Wall time of each stage on this frame, milliseconds, by stage name.
  std::map<std::string, double> timings_ms;
};

}  // namespace shapesense
