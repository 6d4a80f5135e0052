#include "normals/step_map.h"

#include <algorithm>
#include <cmath>

#include "normals/normal_kernels.h"

namespace shapesense::detail {
namespace {

StepRule stepRule(const NormalParams& params) {
  return StepRule{
      static_cast<float>(params.max_depth_change_factor),
      static_cast<float>(params.depth_change_noise_steps * params.noise.disparity_step_px /
                         params.noise.focal_baseline_px_m),
      std::max(0, params.max_gap_px)};
}

// The step across the gap before pixel u, which follows a hole: against the last valid pixel to
// its left, at most max_gap pixels away. The mark goes to that pixel, left of u.
void markAcrossGap(const float* zrow, int u, const StepRule& rule, std::uint8_t* marks) {
  int prev_u = u - 2;  // u - 1 has no depth
  while (prev_u >= 0 && u - prev_u - 1 <= rule.max_gap && !(zrow[prev_u] > 0.0f)) --prev_u;
  if (prev_u < 0 || u - prev_u - 1 > rule.max_gap) return;
  const float a = zrow[u], b = zrow[prev_u];
  const float z = std::min(a, b);
  const int gap = u - prev_u - 1;
  if (std::fabs(a - b) >
      std::max(rule.factor * z * static_cast<float>(gap + 1), rule.noise_k * z * z))
    marks[prev_u] = 1;
}

// Folds the row before (forward pass) or after (backward pass) into d: the 3x3 unit mask's
// neighbours u - 1, u, u + 1 of that row.
void foldNeighbourRow(const std::int16_t* o, int cols, std::int16_t* d) {
  d[0] = std::min({d[0], static_cast<std::int16_t>(o[0] + 1), static_cast<std::int16_t>(o[1] + 1)});
  foldStepDistanceRow(o, cols, d);
  d[cols - 1] = std::min({d[cols - 1], static_cast<std::int16_t>(o[cols - 1] + 1),
                          static_cast<std::int16_t>(o[cols - 2] + 1)});
}

}  // namespace

void markDepthSteps(const NormalParams& params, const NormalInput& input, StepMap& steps) {
  const int rows = input.rows, cols = input.cols;
  // No clearing: the horizontal pass assigns every pixel of a row before the vertical pass of
  // later rows marks any of them.
  steps.marks.create(rows, cols, CV_8UC1);
  const StepRule rule = stepRule(params);
  steps.last_z.assign(cols, 0.0f);
  steps.last_v.assign(cols, -1000000);
  steps.after_hole.resize(static_cast<std::size_t>(cols) + 64);  // + a vector of slack
  for (int v = 0; v < rows; ++v) {
    const float* zrow = input.zRow(v);
    auto* row_marks = steps.marks.ptr<std::uint8_t>(v);
    // Vertical steps go to the rows above (never to row v, which the horizontal pass assigns);
    // then the horizontal ones between neighbours, and across the gap before each pixel that
    // follows a hole (those marks go left of the pixel, to places already assigned).
    markVerticalSteps(zrow, v, cols, rule, steps.last_z.data(), steps.last_v.data(),
                      steps.marks.data, steps.marks.step);
    const int holes = markHorizontalSteps(zrow, cols, rule, row_marks, steps.after_hole.data());
    for (int i = 0; i < holes; ++i) markAcrossGap(zrow, steps.after_hole[i], rule, row_marks);
    row_marks[cols - 1] = 0;
  }
}

// Two raster passes with the 3x3 unit mask, which is exact for the chessboard metric: each row
// folds in its neighbour row of the pass, then a running minimum along the row.
void computeStepDistance(int cap, StepMap& steps) {
  const int rows = steps.marks.rows, cols = steps.marks.cols;
  steps.distance.resize(static_cast<std::size_t>(rows) * cols);
  const auto far = static_cast<std::int16_t>(cap);
  auto row = [&](int v) { return steps.distance.data() + static_cast<std::size_t>(v) * cols; };
  for (int v = 0; v < rows; ++v) {
    initStepDistanceRow(steps.marks.ptr<std::uint8_t>(v), cols, far, row(v));
    if (v > 0 && cols > 1) foldNeighbourRow(row(v - 1), cols, row(v));
    scanStepDistanceRow(row(v), cols, 1);
  }
  for (int v = rows - 1; v >= 0; --v) {
    if (v + 1 < rows && cols > 1) foldNeighbourRow(row(v + 1), cols, row(v));
    scanStepDistanceRow(row(v), cols, -1);
  }
}

}  // namespace shapesense::detail
