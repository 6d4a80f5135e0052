#pragma once
// The normals' SIMD kernels, written once with Google Highway and dispatched at run time to the
// best target the CPU has (the step map's in step_map_kernels.cpp, the input, window radii and
// integral rows in integral_kernels.cpp, the gradient modes' normals in normal_kernels.cpp). Each
// kernel does a whole row (its vector steps, then the last pixels one at a time with the same
// operations) and computes the same bits on every target, the scalar one included: integer work,
// and float work in the order of the scalar definition without fused multiply-adds. At most
// 256-bit vectors (on AVX3 the 512-bit ones made the whole stage slower). Internal to
// core/src/normals/.

#include <cstdint>

namespace shapesense::detail {

/// z (metres) of a depth row in millimetres; NaN where there is no reading.
void depthRowToZ(const std::uint16_t* depth_mm, int cols, float* z);

/// The points z * (ray_x, ray_y, 1) of a row, interleaved (a CV_32FC3 row).
void pointsRow(const float* z, const float* ray_x, float ray_y, int cols, float* xyz);

/// The step rule of markVerticalSteps() and markHorizontalSteps(): neighbours za, zb (metres),
/// with `gap` invalid pixels between them, are on different surfaces when
/// |za - zb| > max(factor * zmin * (gap + 1), noise_k * zmin^2), zmin = min(za, zb).
struct StepRule {
  float factor;
  float noise_k;
  int max_gap;
};

/// The vertical steps of row `v`: each valid pixel against the last valid pixel above it in its
/// column (`last_z`, `last_v`, updated), across at most max_gap invalid pixels. A step marks the
/// upper pixel, in `marks` (row stride `marks_stride`), a row before v.
void markVerticalSteps(const float* zrow, int v, int cols, const StepRule& rule, float* last_z,
                       int* last_v, std::uint8_t* marks, std::size_t marks_stride);

/// The horizontal steps of a row between valid neighbours: marks[u - 1] = step between u - 1 and
/// u, for every u in 1..cols-1 (marks[cols - 1] is left alone). Lists the valid pixels that
/// follow an invalid one in `after_hole` (their steps across the gap are the caller's) and
/// returns how many.
int markHorizontalSteps(const float* zrow, int cols, const StepRule& rule, std::uint8_t* marks,
                        int* after_hole);

/// Step distance rows: d = `far` except 0 on marks.
void initStepDistanceRow(const std::uint8_t* marks, int cols, std::int16_t far, std::int16_t* d);
/// d[u] = min(d[u], min(o[u - 1], o[u], o[u + 1]) + 1) for u in 1..cols-2 (o: the row before or
/// after in the pass).
void foldStepDistanceRow(const std::int16_t* o, int cols, std::int16_t* d);
/// The running minimum d[u] = min(d[u], d[u - dir] + 1) along the row (dir 1: forward from pixel
/// 0; -1: backward from cols - 1).
void scanStepDistanceRow(std::int16_t* d, int cols, int dir);

/// The gradient modes' window radius of every pixel of a row (0: no normal): the range-scaled
/// radius base_r * z + const_r, rounded, within [min_r, max_r], the column bound, the row bound
/// `row_bound` and the step distance - 2 (the four windows of radius r reach r + 1), 0 below
/// min_r or without depth.
struct RadiusRule {
  float base_r, const_r;
  float min_r, max_r;
  float row_bound;
};
void windowRadiusRow(const float* zrow, const std::int16_t* step_distance,
                     const float* column_bound, int cols, const RadiusRule& rule, int* radius);

/// The 3D-gradient integral image's elements of a row of point input: (x, y, z, count) per
/// pixel in 0.1 mm fixed point (truncated), 0 where z is invalid.
void gradientElementsFromPoints(const float* xyz, int cols, std::uint32_t* elements);
/// Integral row of the 3D gradient: `row` = `above` + the running sum of the row's elements
/// (both cols + 1 elements, the first zero; wrapping uint32).
void integrateGradientRow(const std::uint32_t* elements, int cols, const std::uint32_t* above,
                          std::uint32_t* row);
/// The same from depth input (the points are z times the rays), without the elements' buffer.
void integrateGradientRowFromDepth(const float* z, const float* ray_x, float ray_y, int cols,
                                   const std::uint32_t* above, std::uint32_t* row);
/// Integral row of the depth change: (count, z) pairs (z as above) as uint64, count in the low
/// half; `row` = `above` + the running sum (cols + 1 pairs, the first zero).
void integrateDepthChangeRow(const float* z, int cols, const std::uint32_t* above,
                             std::uint32_t* row);

struct GradientRow;  // gradient_windows.h
/// The unit normals of one output row of the 3D-gradient or the depth-change mode (see
/// gradient_windows.h): several pixels per step where the valid ones share a radius, the others
/// one at a time.
void gradientNormalsRow(const GradientRow& row);
void depthChangeNormalsRow(const GradientRow& row);

}  // namespace shapesense::detail
