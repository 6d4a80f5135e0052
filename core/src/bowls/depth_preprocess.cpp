#include "shapesense/core/bowls/depth_preprocess.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "bowls/bowl_preprocess_kernels.h"

namespace shapesense {

int fillInvalidRecursiveMedian(cv::Mat& depth_mm, int passes) {
  if (depth_mm.type() != CV_16UC1)
    throw std::invalid_argument("fillInvalidRecursiveMedian: need CV_16UC1");
  const int rows = depth_mm.rows, cols = depth_mm.cols;
  int remaining = 0;
  for (int r = 0; r < rows; ++r) {
    const auto* p = depth_mm.ptr<std::uint16_t>(r);
    remaining += static_cast<int>(std::count(p, p + cols, std::uint16_t{0}));
  }
  // Rows beyond the border read as invalid; padded so that block loads stay inside.
  const std::vector<std::uint16_t> no_row(static_cast<std::size_t>(cols) + 16, 0);
  for (int pass = 0; pass < passes && remaining > 0; ++pass) {
    const bool forward = pass % 2 == 0;
    for (int i = 0; i < rows; ++i) {
      const int r = forward ? i : rows - 1 - i;
      std::uint16_t* row = depth_mm.ptr<std::uint16_t>(r);
      const std::uint16_t* above = r > 0 ? depth_mm.ptr<std::uint16_t>(r - 1) : no_row.data();
      const std::uint16_t* below =
          r + 1 < rows ? depth_mm.ptr<std::uint16_t>(r + 1) : no_row.data();
      remaining -= bowls::fillHolesInRow(above, row, below, cols, forward);
    }
  }
  return remaining;
}

DepthTo8BitMap::DepthTo8BitMap(const DepthPreprocessParams& params) : params_(params) {
  if (!(params.far_m > params.near_m) || params.low < 0 || params.high > 255 ||
      params.low >= params.high)
    throw std::invalid_argument("DepthTo8BitMap: bad range");
  // One lookup table over all 16-bit values: the mapping is then a single gather per pixel.
  // Only the [near, far] part needs arithmetic; below and above are constant (clamping).
  const double near_mm = params.near_m * 1000.0, far_mm = params.far_m * 1000.0;
  const double gain = (params.high - params.low) / (far_mm - near_mm);
  const int lo_end = std::clamp(static_cast<int>(std::ceil(near_mm)), 1, 65536);
  const int hi_begin = std::clamp(static_cast<int>(std::floor(far_mm)) + 1, lo_end, 65536);
  lut_.resize(65536);
  std::fill(lut_.begin() + 1, lut_.begin() + lo_end, static_cast<std::uint8_t>(params.low));
  for (int v = lo_end; v < hi_begin; ++v)
    lut_[v] = static_cast<std::uint8_t>(std::lround(params.low + (v - near_mm) * gain));
  std::fill(lut_.begin() + hi_begin, lut_.end(), static_cast<std::uint8_t>(params.high));
  lut_[0] = static_cast<std::uint8_t>(std::clamp(params.unfilled_value, 0, 255));
}

cv::Mat DepthTo8BitMap::operator()(const cv::Mat& depth_mm) const {
  if (depth_mm.type() != CV_16UC1) throw std::invalid_argument("DepthTo8BitMap: need CV_16UC1");
  const std::uint8_t* lut = lut_.data();
  cv::Mat out(depth_mm.size(), CV_8UC1);
  for (int r = 0; r < depth_mm.rows; ++r) {
    const auto* s = depth_mm.ptr<std::uint16_t>(r);
    auto* d = out.ptr<std::uint8_t>(r);
    for (int c = 0; c < depth_mm.cols; ++c) d[c] = lut[s[c]];
  }
  return out;
}

cv::Mat preprocessDepth(const cv::Mat& depth_mm, const DepthTo8BitMap& map, cv::Mat* filled_mm) {
  cv::Mat filled = depth_mm.clone();
  fillInvalidRecursiveMedian(filled, map.params().fill_passes);
  cv::Mat out = map(filled);
  if (filled_mm) *filled_mm = std::move(filled);
  return out;
}

}  // namespace shapesense
