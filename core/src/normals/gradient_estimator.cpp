#include "normals/gradient_estimator.h"

#include <algorithm>

#include "normals/normal_kernels.h"
#include "normals/step_map.h"

namespace shapesense::detail {
namespace {

// The packed integral image: per element the valid count and the 0.1 mm fixed-point sums, read
// with one load per corner: 4 uint32 (x, y, z, count) for the 3D gradient, one uint64 (count in
// the low half, z in the high half) for the depth change. All sums wrap around; window sums are
// exact because no field of a window sum overflows.
//
// The windows of row v read integral rows v - max_r - 1 to v + max_r + 2 only, so the image
// lives in a ring of that many rows (~0.45 MB at the default max_r instead of ~5 MB): it stays
// in L2 instead of going to memory and back. Integral row y is in slot y % ring_rows.
class IntegralRing {
 public:
  IntegralRing(GradientMode mode, const NormalInput& input, int max_r, GradientBuffers& b)
      : mode_(mode), input_(input), b_(b) {
    const int rows = input.rows;
    words_ = static_cast<std::size_t>(input.cols + 1) * elementWords(mode);
    const int ring_rows = std::min(rows + 1, 2 * max_r + 4);
    // + 4: slack for a group's loads past the last element of the last ring row.
    b.packed.resize(static_cast<std::size_t>(ring_rows) * words_ + 4);
    b.integral_rows.resize(static_cast<std::size_t>(rows) + 1);
    for (int y = 0; y <= rows; ++y)
      b.integral_rows[y] = b.packed.data() + static_cast<std::size_t>(y % ring_rows) * words_;
    std::fill(b.integral_rows[0], b.integral_rows[0] + words_, 0u);
    b.elements.resize(words_);
  }

  const std::uint32_t* const* rows() const { return b_.integral_rows.data(); }

  /// Integrates image rows up to `end` - 1 (integral rows up to `end`).
  void buildUpTo(int end) {
    for (; built_ < end; ++built_) buildRow(built_);
  }

 private:
  // Integral row v + 1 from image row v.
  void buildRow(int v) {
    std::uint32_t* row = b_.integral_rows[v + 1];
    const std::uint32_t* above = b_.integral_rows[v];
    const int cols = input_.cols;
    if (mode_ == GradientMode::kDepthChange) {
      integrateDepthChangeRow(input_.zRow(v), cols, above, row);
    } else if (input_.from_depth) {
      integrateGradientRowFromDepth(input_.zRow(v), input_.ray_x.data(), input_.ray_y[v], cols,
                                    above, row);
    } else {
      std::uint32_t* e = b_.elements.data();
      gradientElementsFromPoints(input_.points.ptr<float>(v), cols, e);
      integrateGradientRow(e, cols, above, row);
    }
  }

  GradientMode mode_;
  const NormalInput& input_;
  GradientBuffers& b_;
  std::size_t words_ = 0;
  int built_ = 0;  // image rows integrated so far
};

// The per-frame tables: 1 / n per window count, the column bound of the radius, the fewest
// valid pixels per radius.
void prepareTables(const NormalParams& params, int cols, int max_r, GradientBuffers& b) {
  // 1 / count by table lookup: the same value as the division, without a division per window.
  const std::size_t max_count =
      static_cast<std::size_t>(2 * max_r + 1) * static_cast<std::size_t>(2 * max_r + 1);
  if (b.inv_count.size() != max_count + 1) {
    b.inv_count.resize(max_count + 1);
    b.inv_count[0] = 0.0f;
    for (std::size_t n = 1; n <= max_count; ++n) b.inv_count[n] = 1.0f / static_cast<float>(n);
  }
  // Largest r that the image width leaves at each column (the four windows reach r + 1).
  b.column_bound.resize(static_cast<std::size_t>(cols));
  for (int u = 0; u < cols; ++u)
    b.column_bound[u] = static_cast<float>(std::min(u, cols - 1 - u) - 1);
  const float min_frac = static_cast<float>(params.min_valid_fraction);
  b.min_count.resize(static_cast<std::size_t>(max_r) + 1);
  for (int r = 0; r <= max_r; ++r) {
    b.min_count[r] =
        std::max(4, static_cast<int>(min_frac * static_cast<float>((2 * r + 1) * (2 * r + 1))));
  }
}

// The window cache of the three rows of centres around row v (slots rotate with v).
void bindWindowRows(GradientMode mode, int v, int cols, GradientBuffers& b, GradientRow& g) {
  const std::size_t plane = static_cast<std::size_t>(cols) * windowChannels(mode);
  g.mean_above = b.window_mean.data() + static_cast<std::size_t>((v + 2) % 3) * plane;
  g.mean_here = b.window_mean.data() + static_cast<std::size_t>(v % 3) * plane;
  g.mean_below = b.window_mean.data() + static_cast<std::size_t>((v + 1) % 3) * plane;
  g.radius_above = b.window_radius.data() + static_cast<std::size_t>((v + 2) % 3) * cols;
  g.radius_here = b.window_radius.data() + static_cast<std::size_t>(v % 3) * cols;
  g.radius_below = b.window_radius.data() + static_cast<std::size_t>((v + 1) % 3) * cols;
  std::fill(g.radius_below, g.radius_below + cols, 0);  // it held the centres of row v - 2
}

}  // namespace

// Per row: the window radius of every pixel, bounded so that the four windows (radius r + 1 in
// all) hold no step mark; then the normals from the cached window means.
void estimateGradientNormals(GradientMode mode, const NormalParams& params,
                             const CameraIntrinsics& intr, NormalWorkspace& work,
                             cv::Mat& normals) {
  const NormalInput& input = work.input;
  GradientBuffers& b = work.gradient;
  const int rows = input.rows, cols = input.cols;
  const int min_r = std::max(1, params.min_radius_px);
  const int max_r = std::max(min_r, params.max_radius_px);
  IntegralRing ring(mode, input, max_r, b);
  prepareTables(params, cols, max_r, b);
  computeStepDistance(std::min(max_r + 3, 30000), work.steps);  // any cap above max_r + 2 is far
  RadiusRule radius_rule;
  radius_rule.base_r = static_cast<float>(params.smoothing_radius_px) *
                       (params.depth_dependent_smoothing ? 1.0f : 0.0f);
  radius_rule.const_r =
      params.depth_dependent_smoothing ? 0.0f : static_cast<float>(params.smoothing_radius_px);
  radius_rule.min_r = static_cast<float>(min_r);
  radius_rule.max_r = static_cast<float>(max_r);
  b.radius.resize(static_cast<std::size_t>(cols));
  b.row_normal.resize(3 * static_cast<std::size_t>(cols));
  b.window_mean.resize(3 * static_cast<std::size_t>(cols) * windowChannels(mode));
  b.window_radius.assign(3 * static_cast<std::size_t>(cols), 0);  // 0: nothing cached
  GradientRow g{};
  g.integral = ring.rows();
  g.inv_count = b.inv_count.data();
  g.radius = b.radius.data();
  g.min_count = b.min_count.data();
  g.normal_x = b.row_normal.data();
  g.normal_y = g.normal_x + cols;
  g.normal_z = g.normal_y + cols;
  g.cols = cols;
  g.fx = static_cast<float>(intr.fx);
  g.fy = static_cast<float>(intr.fy);
  g.cx = static_cast<float>(intr.cx);
  g.cy = static_cast<float>(intr.cy);
  g.ifx = 1.0f / g.fx;
  const float ify = 1.0f / g.fy;
  for (int v = 0; v < rows; ++v) {
    ring.buildUpTo(std::min(rows, v + max_r + 2));  // the windows reach r + 1 rows below v
    // Largest r inside the image vertically (the windows reach r + 1).
    radius_rule.row_bound = static_cast<float>(std::min(v, rows - 1 - v) - 1);
    windowRadiusRow(input.zRow(v), work.steps.distance.data() + static_cast<std::size_t>(v) * cols,
                    b.column_bound.data(), cols, radius_rule, b.radius.data());
    bindWindowRows(mode, v, cols, b, g);
    g.v = v;
    g.ray_y = (static_cast<float>(v) - g.cy) * ify;
    g.out = normals.ptr<float>(v);
    if (mode == GradientMode::k3dGradient)
      gradientNormalsRow(g);
    else
      depthChangeNormalsRow(g);
  }
}

}  // namespace shapesense::detail
