#include "shapesense/core/bowls/depth_preprocess.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <emmintrin.h>

namespace shapesense {

namespace {

// The fill works on 8 pixels of a row at a time. A hole pixel's lower median depends on one
// neighbour the scan has just filled (forward: the left one, backward: the right one); its
// other 7 neighbours are already final (the row behind the scan) or not yet touched in this
// pass (the row ahead, the pixel ahead in the row). So the 7 known neighbours of 8 pixels are
// sorted together in SSE2 lanes, and only the last step is serial: with s the m valid known
// values sorted ascending and L the just-filled neighbour, the lower median of the n = m + 1
// valid values (index m / 2) is clamp(L, s[m/2 - 1], s[m/2]); when L is invalid it is s[(m-1)/2]
// of the m values alone. That is the same value a median of the 8 neighbours gives, at a
// fraction of the cost per pixel, which matters in the large holes of real frames (shadows,
// out-of-range areas) where every pixel is filled.
//
// Values are compared in an "ordered" 16-bit signed form t = (v - 1) ^ 0x8000: valid depths
// 1..65535 map in order to -32768..32766 and the invalid 0 maps to 32767 (kInvalid), above
// every valid value, so the invalid neighbours sort last and the signed SSE2 min/max apply.
constexpr std::int16_t kInvalid = 0x7FFF;

inline std::int16_t toOrdered(std::uint16_t v) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(v - 1) ^ 0x8000);
}
inline std::uint16_t fromOrdered(std::int16_t t) {
  return static_cast<std::uint16_t>((static_cast<std::uint16_t>(t) ^ 0x8000) + 1);
}
inline __m128i toOrdered(__m128i v) {
  return _mm_xor_si128(_mm_sub_epi16(v, _mm_set1_epi16(1)),
                       _mm_set1_epi16(static_cast<short>(0x8000)));
}

/// For 8 pixels: the bounds lo, hi of the clamp and the median mid without the serial neighbour
/// (see above), in the ordered form. mid = kInvalid when a pixel has no valid known neighbour.
struct BlockStats {
  alignas(16) std::int16_t lo[8];
  alignas(16) std::int16_t hi[8];
  alignas(16) std::int16_t mid[8];
};

/// `above`, `here`, `below` point at column c - 1 of the three rows (columns c - 1 .. c + 8
/// readable); the 8 pixels are columns c .. c + 7 of `here`. Forward: the known horizontal
/// neighbour is the right one (c + 1), backward the left one (c - 1).
template <bool Forward>
void blockStats(const std::uint16_t* above, const std::uint16_t* here, const std::uint16_t* below,
                BlockStats& out) {
  auto load = [](const std::uint16_t* p) {
    return toOrdered(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  };
  __m128i s[7] = {load(above), load(above + 1), load(above + 2), load(Forward ? here + 2 : here),
                  load(below), load(below + 1), load(below + 2)};
  // Optimal 16-comparator network for 7 elements (checked on all 0/1 inputs).
  auto exchange = [&s](int i, int j) {
    const __m128i lo = _mm_min_epi16(s[i], s[j]);
    s[j] = _mm_max_epi16(s[i], s[j]);
    s[i] = lo;
  };
  exchange(0, 6), exchange(2, 3), exchange(4, 5);
  exchange(0, 2), exchange(1, 4), exchange(3, 6);
  exchange(0, 1), exchange(2, 5), exchange(3, 4);
  exchange(1, 2), exchange(4, 6);
  exchange(2, 3), exchange(4, 5);
  exchange(1, 2), exchange(3, 4), exchange(5, 6);
  // Invalid values sort last, so s[i] is invalid exactly when i >= m. Selecting by m:
  //   hi  = s[m/2]:          s0, s1 from m >= 2, s2 from m >= 4, s3 from m >= 6;
  //   lo  = s[m/2 - 1]:      lowest for m < 2, s0 from m >= 2, s1 from 4, s2 from 6;
  //   mid = s[(m - 1) / 2]:  s0 (invalid when m = 0), s1 from m >= 3, s2 from 5, s3 from 7.
  const __m128i invalid = _mm_set1_epi16(kInvalid);
  auto atLeast = [&](int m) {
    return _mm_xor_si128(_mm_cmpeq_epi16(s[m - 1], invalid), _mm_set1_epi16(-1));
  };  // i.e. m valid
  auto select = [](__m128i mask, __m128i yes, __m128i no) {
    return _mm_or_si128(_mm_and_si128(mask, yes), _mm_andnot_si128(mask, no));
  };
  const __m128i m2 = atLeast(2), m3 = atLeast(3), m4 = atLeast(4), m5 = atLeast(5), m6 = atLeast(6),
                m7 = atLeast(7);
  const __m128i hi = select(m6, s[3], select(m4, s[2], select(m2, s[1], s[0])));
  const __m128i lo = select(m6, s[2], select(m4, s[1], select(m2, s[0], _mm_set1_epi16(-32768))));
  const __m128i mid = select(m7, s[3], select(m5, s[2], select(m3, s[1], s[0])));
  _mm_store_si128(reinterpret_cast<__m128i*>(out.lo), lo);
  _mm_store_si128(reinterpret_cast<__m128i*>(out.hi), hi);
  _mm_store_si128(reinterpret_cast<__m128i*>(out.mid), mid);
}

/// Bit i set when column c + i of `row` is 0 (8 columns from c).
int zeroMask(const std::uint16_t* row, int c) {
  const __m128i px = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + c));
  return _mm_movemask_epi8(
      _mm_packs_epi16(_mm_cmpeq_epi16(px, _mm_setzero_si128()), _mm_setzero_si128()));
}

/// True when columns c - 1 .. c + 8 of the three rows hold no valid pixel.
bool noValidAround(const std::uint16_t* above, const std::uint16_t* here,
                   const std::uint16_t* below, int c) {
  auto load = [](const std::uint16_t* p) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
  };
  const __m128i any = _mm_or_si128(
      _mm_or_si128(_mm_or_si128(load(above + c - 1), load(here + c - 1)), load(below + c - 1)),
      _mm_or_si128(_mm_or_si128(load(above + c + 1), load(here + c + 1)), load(below + c + 1)));
  return _mm_movemask_epi8(_mm_cmpeq_epi16(any, _mm_setzero_si128())) == 0xFFFF;
}

/// One pass over one row: fills the holes of columns [c, c + 8) ∩ [0, cols) block by block in
/// scan order. Returns the number of pixels filled.
template <bool Forward>
int fillRow(const std::uint16_t* above, std::uint16_t* here, const std::uint16_t* below, int cols) {
  int filled = 0;
  const int blocks = (cols + 7) / 8;
  BlockStats st;
  for (int b = 0; b < blocks; ++b) {
    const int c = 8 * (Forward ? b : blocks - 1 - b);
    const int n = std::min(8, cols - c);  // pixels in this block
    // The serial neighbour's value: final already (it lies behind the scan).
    const int serial_col = Forward ? c - 1 : c + n;
    std::int16_t L = serial_col >= 0 && serial_col < cols ? toOrdered(here[serial_col]) : kInvalid;
    const bool interior = c >= 1 && c + 9 <= cols;
    if (interior) {
      const int holes = zeroMask(here, c);
      if (holes == 0) continue;
      // Inside a large hole with nothing valid near: every pixel stays invalid this pass.
      if (L == kInvalid && noValidAround(above, here, below, c)) continue;
      blockStats<Forward>(above + c - 1, here + c - 1, below + c - 1, st);
    } else {
      // Image border or row end: a copy of columns c - 1 .. c + 8 with 0 (invalid) outside.
      alignas(16) std::uint16_t pad[3][16] = {};
      const std::uint16_t* rows[3] = {above, here, below};
      for (int k = 0; k < 3; ++k)
        for (int x = std::max(0, c - 1); x <= std::min(cols - 1, c + 8); ++x)
          pad[k][x - (c - 1)] = rows[k][x];
      bool any_hole = false;
      for (int i = 0; i < n; ++i) any_hole |= here[c + i] == 0;
      if (!any_hole) continue;
      blockStats<Forward>(pad[0], pad[1], pad[2], st);
    }
    for (int k = 0; k < n; ++k) {
      const int i = Forward ? k : n - 1 - k;
      const std::uint16_t v = here[c + i];
      if (v != 0) {
        L = toOrdered(v);
        continue;
      }
      const std::int16_t t = L == kInvalid ? st.mid[i] : std::max(st.lo[i], std::min(L, st.hi[i]));
      if (t != kInvalid) {
        here[c + i] = fromOrdered(t);
        ++filled;
      }
      L = t;
    }
  }
  return filled;
}

}  // namespace

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
      remaining -= forward ? fillRow<true>(above, row, below, cols)
                           : fillRow<false>(above, row, below, cols);
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
