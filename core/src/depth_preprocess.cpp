#include "shapesense/core/depth_preprocess.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <emmintrin.h>

namespace shapesense {

namespace {

/// Sorts 8 values ascending with a fixed network of 19 compare-exchanges (Batcher's
/// odd-even merge sort): no data-dependent branch, unlike std::nth_element on 8 elements.
void sortEight(std::array<std::uint16_t, 8>& v) {
  auto exchange = [&v](int i, int j) {
    const std::uint16_t lo = std::min(v[i], v[j]), hi = std::max(v[i], v[j]);
    v[i] = lo;
    v[j] = hi;
  };
  exchange(0, 1), exchange(2, 3), exchange(4, 5), exchange(6, 7);
  exchange(0, 2), exchange(1, 3), exchange(4, 6), exchange(5, 7);
  exchange(1, 2), exchange(5, 6);
  exchange(0, 4), exchange(1, 5), exchange(2, 6), exchange(3, 7);
  exchange(2, 4), exchange(3, 5);
  exchange(1, 2), exchange(3, 4), exchange(5, 6);
}

/// Index of the first zero of row[from, to), or `to` if none: 8 pixels per SSE2 compare,
/// since most of a row is valid depth.
int findZero(const std::uint16_t* row, int from, int to) {
  const __m128i zero = _mm_setzero_si128();
  int c = from;
  for (; to - c >= 8; c += 8) {
    const __m128i px = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + c));
    const int mask = _mm_movemask_epi8(_mm_cmpeq_epi16(px, zero));
    if (mask != 0) return c + std::countr_zero(static_cast<unsigned>(mask)) / 2;
  }
  for (; c < to; ++c)
    if (row[c] == 0) return c;
  return to;
}

/// Index of the last zero of row[0, to), or -1 if none.
int findZeroBackward(const std::uint16_t* row, int to) {
  const __m128i zero = _mm_setzero_si128();
  int c = to;
  for (; c >= 8; c -= 8) {
    const __m128i px = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + c - 8));
    const int mask = _mm_movemask_epi8(_mm_cmpeq_epi16(px, zero));
    if (mask != 0) return c - 1 - std::countl_zero(static_cast<unsigned>(mask) << 16) / 2;
  }
  while (--c >= 0)
    if (row[c] == 0) return c;
  return -1;
}

/// True where column c of the three rows holds a valid pixel, for 8 columns from c (SSE2).
int validColumnsMask(const std::uint16_t* above, const std::uint16_t* here,
                     const std::uint16_t* below, int c) {
  auto load = [c](const std::uint16_t* row) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + c));
  };
  const __m128i any = _mm_or_si128(_mm_or_si128(load(above), load(here)), load(below));
  return ~_mm_movemask_epi8(_mm_cmpeq_epi16(any, _mm_setzero_si128())) & 0xFFFF;
}

/// The first column in [from, to) where one of the three rows is valid, or `to`.
int firstValidColumn(const std::uint16_t* above, const std::uint16_t* here,
                     const std::uint16_t* below, int from, int to) {
  int c = from;
  for (; to - c >= 8; c += 8)
    if (const int mask = validColumnsMask(above, here, below, c); mask != 0)
      return c + std::countr_zero(static_cast<unsigned>(mask)) / 2;
  for (; c < to; ++c)
    if ((above[c] | here[c] | below[c]) != 0) return c;
  return to;
}

/// The last column in [0, to) where one of the three rows is valid, or -1.
int lastValidColumn(const std::uint16_t* above, const std::uint16_t* here,
                    const std::uint16_t* below, int to) {
  int c = to;
  for (; c >= 8; c -= 8)
    if (const int mask = validColumnsMask(above, here, below, c - 8); mask != 0)
      return c - 1 - std::countl_zero(static_cast<unsigned>(mask) << 16) / 2;
  while (--c >= 0)
    if ((above[c] | here[c] | below[c]) != 0) return c;
  return -1;
}

/// Fills the invalid pixel (r, c) with the lower median of its valid 8-neighbours; returns
/// false (and leaves it) when it has none.
bool fillFromNeighbours(cv::Mat& depth_mm, int r, int c) {
  // Neighbours are shifted down by one (mod 2^16) before sorting, so that invalid (0) and
  // missing ones become 65535, above every valid one (at most 65534 after the shift): the
  // k-th smallest of the n valid values is then the k-th element of the sorted eight.
  std::array<std::uint16_t, 8> nb;
  int n = 0;
  if (r > 0 && r + 1 < depth_mm.rows && c > 0 && c + 1 < depth_mm.cols) {
    // Inside the image (nearly every hole pixel): the 8 neighbours without bounds checks.
    const std::uint16_t* above = depth_mm.ptr<std::uint16_t>(r - 1) + c - 1;
    const std::uint16_t* here = depth_mm.ptr<std::uint16_t>(r) + c - 1;
    const std::uint16_t* below = depth_mm.ptr<std::uint16_t>(r + 1) + c - 1;
    const std::array<std::uint16_t, 8> v = {above[0], above[1], above[2], here[0],
                                            here[2],  below[0], below[1], below[2]};
    for (std::size_t k = 0; k < 8; ++k) {
      nb[k] = static_cast<std::uint16_t>(v[k] - 1);
      n += v[k] != 0;
    }
  } else {
    nb.fill(0xFFFF);
    std::size_t k = 0;
    for (int dr = -1; dr <= 1; ++dr) {
      const int rr = r + dr;
      if (rr < 0 || rr >= depth_mm.rows) continue;
      const auto* q = depth_mm.ptr<std::uint16_t>(rr);
      for (int dc = -1; dc <= 1; ++dc) {
        const int cc = c + dc;
        if ((dr == 0 && dc == 0) || cc < 0 || cc >= depth_mm.cols) continue;
        nb[k++] = static_cast<std::uint16_t>(q[cc] - 1);
        n += q[cc] != 0;
      }
    }
  }
  if (n == 0) return false;
  // Inside a large hole the fill copies one surface's value along: when every valid neighbour
  // holds the same value, that value is the median and the sort is not needed.
  std::uint16_t lowest = nb[0], highest = 0;
  for (std::size_t k = 0; k < 8; ++k) {
    lowest = std::min(lowest, nb[k]);
    highest = std::max(highest, static_cast<std::uint16_t>(nb[k] + 1));  // invalid ones: 0
  }
  if (static_cast<std::uint16_t>(lowest + 1) == highest) {
    depth_mm.ptr<std::uint16_t>(r)[c] = highest;
    return true;
  }
  sortEight(nb);
  // Lower median for even counts: keeps the fill on the nearer surface at an edge less
  // often than the mean would smear across it; any fixed choice is fine for detection.
  depth_mm.ptr<std::uint16_t>(r)[c] =
      static_cast<std::uint16_t>(nb[static_cast<std::size_t>((n - 1) / 2)] + 1);
  return true;
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
  // Visiting only the zeros of a row in raster order is the same as visiting every pixel:
  // filling a pixel changes no pixel ahead of it in its row, so the zeros ahead stay where the
  // search finds them.
  // A pixel that stays invalid has no valid neighbour, so the next pixel in scan order stays
  // invalid too unless the column after it holds a valid pixel: in a large hole (a room that
  // reads no depth) whole runs are skipped by a search for the next valid column.
  const std::vector<std::uint16_t> no_row(static_cast<std::size_t>(cols), 0);  // beyond the border
  for (int pass = 0; pass < passes && remaining > 0; ++pass) {
    const bool forward = pass % 2 == 0;
    for (int i = 0; i < rows; ++i) {
      const int r = forward ? i : rows - 1 - i;
      const std::uint16_t* row = depth_mm.ptr<std::uint16_t>(r);
      const std::uint16_t* above = r > 0 ? depth_mm.ptr<std::uint16_t>(r - 1) : no_row.data();
      const std::uint16_t* below =
          r + 1 < rows ? depth_mm.ptr<std::uint16_t>(r + 1) : no_row.data();
      if (forward) {
        for (int c = findZero(row, 0, cols); c < cols; c = findZero(row, c + 1, cols)) {
          if (fillFromNeighbours(depth_mm, r, c))
            --remaining;
          else  // columns c and c + 1 are empty; pixels before the next valid column - 1 stay
            c = std::max(c, firstValidColumn(above, row, below, std::min(c + 2, cols), cols) - 2);
        }
      } else {
        for (int c = findZeroBackward(row, cols); c >= 0; c = findZeroBackward(row, c)) {
          if (fillFromNeighbours(depth_mm, r, c))
            --remaining;
          else
            c = std::min(c, lastValidColumn(above, row, below, std::max(c - 1, 0)) + 2);
        }
      }
    }
  }
  return remaining;
}

cv::Mat mapDepthTo8Bit(const cv::Mat& depth_mm, const DepthPreprocessParams& params) {
  if (depth_mm.type() != CV_16UC1) throw std::invalid_argument("mapDepthTo8Bit: need CV_16UC1");
  if (!(params.far_m > params.near_m) || params.low < 0 || params.high > 255 ||
      params.low >= params.high)
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

cv::Mat preprocessDepth(const cv::Mat& depth_mm, const DepthPreprocessParams& params,
                        cv::Mat* filled_mm) {
  cv::Mat filled = depth_mm.clone();
  fillInvalidRecursiveMedian(filled, params.fill_passes);
  cv::Mat out = mapDepthTo8Bit(filled, params);
  if (filled_mm) *filled_mm = std::move(filled);
  return out;
}

}  // namespace shapesense
