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

/// One component of the smoothed inverse depth's gradient at a pixel, from the values `before`
/// and `after` at -g and +g pixels along it (<= 0: none): the central difference, else a
/// one-sided one with the pixel's own value, else 0. One-sided differences keep the prediction
/// usable next to holes.
inline float inverseDepthSlope(float before, float centre, float after, int g) {
  const float span = static_cast<float>(g);
  if (before > 0.0f && after > 0.0f) return (after - before) / (2.0f * span);
  if (before > 0.0f && centre > 0.0f) return (centre - before) / span;
  if (after > 0.0f && centre > 0.0f) return (after - centre) / span;
  return 0.0f;
}

/// Row v of the smoothed inverse depth's gradient over +-g pixels (inverseDepthSlope): gx from
/// `row`, gy from `up` and `down`, the rows v - g and v + g (null where off the image). 0 in the
/// g columns at either end.
void inverseDepthGradientRow(const float* up, const float* row, const float* down, int g, int cols,
                             float* gx, float* gy);

/// Plane prediction's rule for one neighbour: its inverse depth `neighbour` is off the
/// prediction from the centre's inverse depth and gradient, (centre + gy * dv) + gx * du, by more
/// than `threshold`. A neighbour without a reading is NaN, which is never off: no comparison with
/// NaN holds, so the rule needs no test for it.
inline bool predictionAnomaly(float centre, float gx, float gy, float neighbour, float du, float dv,
                              float threshold) {
  const float predicted = (centre + gy * dv) + gx * du;
  return std::fabs(neighbour - predicted) > threshold;
}

/// A neighbour of plane prediction: its offset (du, dv), the inverse-depth row v + dv (readable
/// at every column u + du of the pixels counted; NaN = no reading), and its ring's threshold.
/// Neighbours of one row given one after another share the part of the prediction along v.
struct PredictionNeighbour {
  const float* row = nullptr;
  int du = 0, dv = 0;
  float threshold = 0.0f;
  bool long_range = false;  ///< a neighbour of the long-range ring, else of the dense window
};

/// Plane prediction's edge strength of row v: each pixel's count of anomalous neighbours
/// (predictionAnomaly) into `edges` and, when it is not null, the count of the dense window's
/// alone into `short_edges`; kNoDepth where `inverse`, the row's inverse depth, is 0 (no
/// reading). The prediction starts from `smoothed` where it is > 0, else from `inverse`.
/// `neighbours`: the dense window's first. Each pixel's centre, gradient and counts stay in
/// registers across the neighbours.
void predictionEdgesRow(const float* inverse, const float* smoothed, const float* gx,
                        const float* gy, const PredictionNeighbour* neighbours, int count, int cols,
                        std::uint8_t* edges, std::uint8_t* short_edges);

/// One row of a label image's uniform pixels: out[u] = 255 where the 3 x 3 window around u in
/// the rows `above`, `row`, `below` holds row[u]'s label only, else 0; 0 in the first and last
/// column.
void uniformLabelRow(const std::int32_t* above, const std::int32_t* row, const std::int32_t* below,
                     int cols, std::uint8_t* out);

/// One row of planes_and_objects' first labels: out[u] = the plane's id where plane[u] != 0,
/// else plane_count + object[u] where the pixel has depth and an object region, else 0.
void overlayObjectsRow(const std::uint16_t* depth, const std::uint16_t* plane,
                       const std::uint16_t* object, int plane_count, int cols, std::int32_t* out);

/// A run of one label in a row: columns [begin, end).
struct LabelRun {
  int begin = 0, end = 0;
  std::int32_t label = 0;
};

/// The runs of equal labels of a row of `cols` labels, left to right, into `runs` (cleared
/// first).
void labelRuns(const std::int32_t* row, int cols, std::vector<LabelRun>& runs);

}  // namespace shapesense::segmentation
