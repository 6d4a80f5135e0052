#pragma once
// The window means of the gradient modes, one pixel at a time: the reference the row kernels
// (normal_kernels.h) match bit for bit, and what they fall back to for the pixels no group covers
// (a row's last pixels, groups at the outermost columns). Internal to core/src/normals/.
//
// Every pixel's normal comes from the means of four windows of its radius r, centred one pixel
// left, right, up and down. A window centred on (x, y) is read by up to four pixels, so its mean
// (and its valid count) is cached per centre and radius for the three rows of centres in use:
// where neighbours share a radius each pixel computes one new window instead of four. The cache
// is planar (channel k of a row of centres at k * cols), so consecutive centres are one vector
// per channel. Window sums are exact integers, so a mean has the same bits however it is
// computed.

#include <cstdint>

namespace shapesense::detail {

enum class GradientMode {
  k3dGradient,   // cross product of the horizontal and vertical differences of mean points
  kDepthChange,  // normal from the mean depth derivatives and the pinhole model
};

/// uint32 per integral-image element, and floats per cached window (the means, then the count).
constexpr int elementWords(GradientMode mode) { return mode == GradientMode::k3dGradient ? 4 : 2; }
constexpr int windowChannels(GradientMode mode) {
  return mode == GradientMode::k3dGradient ? 4 : 2;
}

/// One output row of a gradient mode: its inputs, the window cache and the output.
struct GradientRow {
  float* mean_above;  // window-mean cache of the rows of centres v - 1, v, v + 1
  float* mean_here;
  float* mean_below;
  int* radius_above;  // the radius each cached centre holds, 0 = none
  int* radius_here;
  int* radius_below;
  const std::uint32_t* const* integral;  // integral rows (elementWords uint32 per element)
  const float* inv_count;                // 1 / n for every window count n
  const int* radius;                     // this row's window radii, 0 = no normal
  const int* min_count;                  // fewest valid pixels per radius
  float* normal_x;                       // scratch: unnormalised normals of the row
  float* normal_y;
  float* normal_z;
  int cols, v;
  float fx, fy, cx, cy;  // intrinsics
  float ifx, ray_y;      // ray x = (u - cx) * ifx; ray y of this row
  float* out;            // the CV_32FC3 output row
};

/// Caches the mean of the window of radius r centred on column x of the row of centres y.
template <GradientMode M>
void cacheWindow(const GradientRow& g, float* means, int* radii, int x, int y, int r);

/// The unnormalised normal of pixel u into g.normal_x/y/z[u]; 0 where there is none.
template <GradientMode M>
void unnormalisedNormal(const GradientRow& g, int u);

/// The unit normals of pixels begin..end-1 from g.normal_x/y/z, facing the camera; NaN where
/// the unnormalised normal is (near) zero.
void normalizePixels(const GradientRow& g, int begin, int end);

}  // namespace shapesense::detail
