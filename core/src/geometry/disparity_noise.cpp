#include "shapesense/core/geometry/disparity_noise.h"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace shapesense {

double disparityNoisePx(const cv::Mat& depth_mm, const KinectNoiseModel& sensor) {
  CV_Assert(depth_mm.empty() || depth_mm.type() == CV_16UC1);
  constexpr double kEdgePx = 1.5;
  constexpr long kMinTriples = 100;
  const double px_mm = sensor.focal_baseline_px_m * 1000.0;  // disparity = px_mm / depth_mm
  double sum = 0.0;
  long triples = 0;
  std::vector<double> disparity(static_cast<std::size_t>(depth_mm.cols));  // 0: no reading
  for (int r = 0; r < depth_mm.rows; ++r) {
    const auto* row = depth_mm.ptr<std::uint16_t>(r);
    for (int c = 0; c < depth_mm.cols; ++c) disparity[c] = row[c] ? px_mm / row[c] : 0.0;
    for (int c = 1; c + 1 < depth_mm.cols; ++c) {
      if (!row[c - 1] || !row[c] || !row[c + 1]) continue;
      const double second = std::abs(disparity[c - 1] - 2.0 * disparity[c] + disparity[c + 1]);
      if (second >= kEdgePx) continue;
      sum += second;
      ++triples;
    }
  }
  if (triples < kMinTriples) return 0.0;
  // For a zero-mean Gaussian, E|e| = sigma_e sqrt(2 / pi), and sigma_e = sqrt(6) sigma.
  const double mean_abs = sum / static_cast<double>(triples);
  return mean_abs * std::sqrt(std::numbers::pi / 2.0) / std::sqrt(6.0);
}

}  // namespace shapesense
