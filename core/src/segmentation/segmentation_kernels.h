#pragma once
// The SIMD kernels of segmentation (Google Highway, dispatched at run time to the best target
// the CPU has). Every kernel is integer work or elementwise float work without fused
// multiply-add, so every target computes the same bits as the scalar per-pixel rules below,
// which the kernels also use for the pixels a vector does not cover.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace shapesense::segmentation {

/// Edge strength of pixels without depth.
constexpr std::uint8_t kNoDepth = 255;

/// One working-resolution pixel from the 2x2 block q of full-resolution readings (mm, 0 = none):
/// the rounded mean of the readings within `k` * nearest^2 + 1 mm of the nearest one, 0 when
/// the block has no reading. `k` is 3 quantisation steps in mm^-1 (see makeWorking).
inline std::uint16_t reduceBlock(const std::uint16_t (&q)[4], float k) {
  unsigned nearest = 0xFFFF;
  for (auto x : q)
    if (x != 0 && x < nearest) nearest = x;
  if (nearest == 0xFFFF) return 0;
  const unsigned limit =
      nearest +
      static_cast<unsigned>(k * static_cast<float>(nearest) * static_cast<float>(nearest)) + 1;
  unsigned sum = 0, n = 0;
  for (auto x : q) {
    if (x != 0 && x <= limit) {
      sum += x;
      ++n;
    }
  }
  return static_cast<std::uint16_t>((sum + n / 2) / n);
}

/// The depth tolerance (mm) of a working pixel of depth z (mm) when its label is spread over
/// its full-resolution pixels: `k` * z^2 + 2, at most 65535.
inline std::uint16_t blockTolerance(float k, float z) {
  return static_cast<std::uint16_t>(std::min(k * z * z + 2.0f, 65535.0f));
}

/// The rows a depth-step count reads around one image row.
struct StepWindow {
  int radius = 1;  ///< Chebyshev radius r of the window, 1..7
  /// The 2r + 1 depth rows v - r .. v + r (nullptr: outside the image).
  const std::uint16_t* const* rows = nullptr;
  /// Row v of the threshold image of each ring 1..r (uint16 mm).
  const std::uint16_t* const* thresholds = nullptr;
  /// Window offsets whose row is inside the image.
  int offsets = 0;
};

/// Per pixel u of the depth row `centre`: the number of window neighbours with depth whose
/// depth differs by more than their ring's threshold; kNoDepth where the centre has no depth.
void countDepthSteps(const std::uint16_t* centre, const StepWindow& window, int cols,
                     std::uint8_t* edges);

/// One row of makeWorking's 2x2 reduction: output pixel u from columns 2u, 2u + 1 of the
/// full-resolution rows `a` and `b` (see reduceBlock).
void reduceRow(const std::uint16_t* a, const std::uint16_t* b, int cols, float k,
               std::uint16_t* out);

/// Flood seeds: the labelled pixels (> 0) of `labels` (rows x cols, contiguous) with an
/// unlabelled 4-neighbour, pushed in raster order into the bucket of their edge strength.
void collectFloodSeeds(const std::int32_t* labels, const std::uint8_t* edges, int rows, int cols,
                       std::array<std::vector<int>, 256>& buckets);

/// One working row spread over full-resolution columns 0..cols: each block's label, depth and
/// depth tolerance (blockTolerance) twice. Working columns past `working_cols` repeat the last.
void expandBlockRow(const std::uint16_t* labels, const std::uint16_t* depth, int working_cols,
                    int cols, float k, std::uint16_t* labels2, std::uint16_t* depth2,
                    std::uint16_t* tolerance2);

/// One full-resolution row: out = the block label where there is depth (else 0), bad = 1 where
/// the depth is off the block's by more than its tolerance. Returns whether any is bad.
bool labelFullRow(const std::uint16_t* depth, const std::uint16_t* labels2,
                  const std::uint16_t* depth2, const std::uint16_t* tolerance2, int cols,
                  std::uint16_t* out, std::uint8_t* bad);

/// Plane prediction's rule for one neighbour: its inverse depth `neighbour` is a reading (> 0)
/// off the prediction from the centre's inverse depth and gradient, centre + gx * du + gy * dv,
/// by more than `threshold`.
inline bool predictionAnomaly(float centre, float gx, float gy, float neighbour, float du, float dv,
                              float threshold) {
  const float predicted = centre + gx * du + gy * dv;
  return (neighbour > 0.0f) & (std::fabs(neighbour - predicted) > threshold);
}

/// A neighbour of plane prediction: its offset (du, dv), the inverse-depth row v + dv (readable
/// at every column u + du of the pixels counted; 0 = no reading), and its ring's threshold.
struct PredictionNeighbour {
  const float* row = nullptr;
  int du = 0, dv = 0;
  float threshold = 0.0f;
  bool long_range = false;  ///< counts into the long-range counts, else the short-range ones
};

/// Row v's pixels u in [0, cols) against their `count` neighbours: the short- and long-range
/// counts of predictionAnomaly are added to counts_short[u] and counts_long[u]. Each pixel's
/// centre, gradient and counts stay in registers across the neighbours.
void countPredictionAnomaliesRow(const float* centre, const float* gx, const float* gy,
                                 const PredictionNeighbour* neighbours, int count, int cols,
                                 std::uint8_t* counts_short, std::uint8_t* counts_long);

/// One row of a label image's uniform pixels: out[u] = 255 where the 3 x 3 window around u in
/// the rows `above`, `row`, `below` holds row[u]'s label only, else 0; 0 in the first and last
/// column.
void uniformLabelRow(const std::int32_t* above, const std::int32_t* row, const std::int32_t* below,
                     int cols, std::uint8_t* out);

/// A run of one label in a row: columns [begin, end).
struct LabelRun {
  int begin = 0, end = 0;
  std::int32_t label = 0;
};

/// The runs of equal labels of a row of `cols` labels, left to right, into `runs` (cleared
/// first).
void labelRuns(const std::int32_t* row, int cols, std::vector<LabelRun>& runs);

}  // namespace shapesense::segmentation
