#include "shapesense/core/depth_preprocess.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace shapesense {

int fillInvalidRecursiveMedian(cv::Mat& depth_mm, int passes) {
  if (depth_mm.type() != CV_16UC1) throw std::invalid_argument("fillInvalidRecursiveMedian: need CV_16UC1");
  const int rows = depth_mm.rows, cols = depth_mm.cols;
  int remaining = 0;
  for (int r = 0; r < rows; ++r) {
    const auto* p = depth_mm.ptr<std::uint16_t>(r);
    remaining += static_cast<int>(std::count(p, p + cols, std::uint16_t{0}));
  }
  std::array<std::uint16_t, 8> nb{};
  for (int pass = 0; pass < passes && remaining > 0; ++pass) {
    const bool forward = pass % 2 == 0;
    for (int i = 0; i < rows; ++i) {
      const int r = forward ? i : rows - 1 - i;
      auto* row = depth_mm.ptr<std::uint16_t>(r);
      for (int j = 0; j < cols; ++j) {
        const int c = forward ? j : cols - 1 - j;
        if (row[c] != 0) continue;
        int n = 0;
        for (int dr = -1; dr <= 1; ++dr) {
          const int rr = r + dr;
          if (rr < 0 || rr >= rows) continue;
          const auto* q = depth_mm.ptr<std::uint16_t>(rr);
          for (int dc = -1; dc <= 1; ++dc) {
            const int cc = c + dc;
            if ((dr == 0 && dc == 0) || cc < 0 || cc >= cols) continue;
            if (q[cc] != 0) nb[n++] = q[cc];
          }
        }
        if (n == 0) continue;
        // Lower median for even counts: keeps the fill on the nearer surface at an edge less
        // often than the mean would smear across it; any fixed choice is fine for detection.
        std::nth_element(nb.begin(), nb.begin() + (n - 1) / 2, nb.begin() + n);
        row[c] = nb[(n - 1) / 2];
        --remaining;
      }
    }
  }
  return remaining;
}

cv::Mat mapDepthTo8Bit(const cv::Mat& depth_mm, const DepthPreprocessParams& params) {
  if (depth_mm.type() != CV_16UC1) throw std::invalid_argument("mapDepthTo8Bit: need CV_16UC1");
  if (!(params.far_m > params.near_m) || params.low < 0 || params.high > 255 || params.low >= params.high)
    throw std::invalid_argument("mapDepthTo8Bit: bad range");
  // One lookup table over all 16-bit values: the mapping is then a single gather per pixel.
  // Only the [near, far] part needs arithmetic; below and above are constant (clamping).
  const double near_mm = params.near_m * 1000.0, far_mm = params.far_m * 1000.0;
  const double gain = (params.high - params.low) / (far_mm - near_mm);
  const int lo_end = std::clamp(static_cast<int>(std::ceil(near_mm)), 1, 65536);
  const int hi_begin = std::clamp(static_cast<int>(std::floor(far_mm)) + 1, lo_end, 65536);
  std::vector<std::uint8_t> lut(65536);
  std::fill(lut.begin() + 1, lut.begin() + lo_end, static_cast<std::uint8_t>(params.low));
  for (int v = lo_end; v < hi_begin; ++v)
    lut[v] = static_cast<std::uint8_t>(std::lround(params.low + (v - near_mm) * gain));
  std::fill(lut.begin() + hi_begin, lut.end(), static_cast<std::uint8_t>(params.high));
  lut[0] = static_cast<std::uint8_t>(std::clamp(params.unfilled_value, 0, 255));
  cv::Mat out(depth_mm.size(), CV_8UC1);
  for (int r = 0; r < depth_mm.rows; ++r) {
    const auto* s = depth_mm.ptr<std::uint16_t>(r);
    auto* d = out.ptr<std::uint8_t>(r);
    for (int c = 0; c < depth_mm.cols; ++c) d[c] = lut[s[c]];
  }
  return out;
}

cv::Mat preprocessDepth(const cv::Mat& depth_mm, const DepthPreprocessParams& params, cv::Mat* filled_mm) {
  cv::Mat filled = depth_mm.clone();
  fillInvalidRecursiveMedian(filled, params.fill_passes);
  cv::Mat out = mapDepthTo8Bit(filled, params);
  if (filled_mm) *filled_mm = std::move(filled);
  return out;
}

}  // namespace shapesense
