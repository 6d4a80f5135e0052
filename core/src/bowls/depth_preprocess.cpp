#include "shapesense/core/bowls/depth_preprocess.h"

#include <algorithm>
#include <cmath>
#include <optional>
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

struct DepthTo8BitMap::FixedPoint {
  bowls::FixedPointDepthMap map;
};

namespace {

/// A fixed-point form of the table, its ramp [ramp_begin, ramp_end) as (v * gain + offset) >>
/// shift: the finest shift whose rounded gain and offset (or an offset a unit or two off) give
/// every one of the table's 65536 values, if any does.
std::optional<bowls::FixedPointDepthMap> fixedPointOf(const std::vector<std::uint8_t>& lut,
                                                      int ramp_begin, int ramp_end, double near_mm,
                                                      double gain, double low) {
  bowls::FixedPointDepthMap map;
  map.ramp_begin = ramp_begin;
  map.ramp_end = ramp_end;
  map.unfilled = lut[0];
  map.low = lut[1];  // only read below the ramp, which then starts past 1
  map.high = lut[65535];
  for (int shift = 24; shift >= 8; --shift) {
    const double scale = std::ldexp(1.0, shift);
    const double a = std::round(gain * scale);
    const double b = std::round((low - near_mm * gain + 0.5) * scale);
    // The largest intermediate, (ramp_end - 1) * gain + offset, must fit in 31 bits.
    if (a < 0 || b < -2147483647.0 || (ramp_end - 1) * a + std::abs(b) + 2 >= 2147483647.0)
      continue;
    for (int nudge = -2; nudge <= 2; ++nudge) {
      map.shift = shift;
      map.gain = static_cast<std::int32_t>(a);
      map.offset = static_cast<std::int32_t>(b) + nudge;
      bool exact = true;
      for (int v = 0; v < 65536 && exact; ++v)
        exact = map.at(static_cast<std::uint16_t>(v)) == lut[static_cast<std::size_t>(v)];
      if (exact) return map;
    }
  }
  return std::nullopt;
}

}  // namespace

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
  if (hi_begin > lo_end && hi_begin < 65536)
    if (const auto fixed = fixedPointOf(lut_, lo_end, hi_begin, near_mm, gain, params.low))
      fixed_point_ = std::make_shared<const FixedPoint>(FixedPoint{*fixed});
}

cv::Mat DepthTo8BitMap::operator()(const cv::Mat& depth_mm) const {
  if (depth_mm.type() != CV_16UC1) throw std::invalid_argument("DepthTo8BitMap: need CV_16UC1");
  const std::uint8_t* lut = lut_.data();
  cv::Mat out(depth_mm.size(), CV_8UC1);
  for (int r = 0; r < depth_mm.rows; ++r) {
    const auto* s = depth_mm.ptr<std::uint16_t>(r);
    auto* d = out.ptr<std::uint8_t>(r);
    if (fixed_point_) {
      bowls::mapDepthRow(s, depth_mm.cols, fixed_point_->map, d);
      continue;
    }
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
