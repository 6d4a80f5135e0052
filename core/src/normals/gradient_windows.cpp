#include "normals/gradient_windows.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace shapesense::detail {
namespace {

std::uint64_t loadPair(const std::uint32_t* p) {
  std::uint64_t x;
  std::memcpy(&x, p, sizeof x);
  return x;
}

}  // namespace

template <GradientMode M>
void cacheWindow(const GradientRow& g, float* means, int* radii, int x, int y, int r) {
  if (radii[x] == r) return;
  radii[x] = r;
  constexpr int L = elementWords(M);
  const int cols = g.cols;
  const std::ptrdiff_t dh = (2 * r + 1) * L;
  const std::uint32_t* a = g.integral[y - r] + (x - r) * L;      // top left
  const std::uint32_t* c = g.integral[y + r + 1] + (x - r) * L;  // bottom left
  if constexpr (M == GradientMode::k3dGradient) {
    // Wrapped four-corner differences: exact whenever the window sum fits.
    std::uint32_t s[4];
    for (int k = 0; k < 4; ++k) s[k] = c[dh + k] - a[dh + k] - c[k] + a[k];
    const float inv = g.inv_count[s[3]];
    for (int k = 0; k < 3; ++k)
      means[k * cols + x] = static_cast<float>(static_cast<std::int32_t>(s[k])) * inv;
    means[3 * cols + x] = static_cast<float>(static_cast<int>(s[3]));
  } else {
    const std::uint64_t s = loadPair(c + dh) - loadPair(a + dh) - loadPair(c) + loadPair(a);
    const auto n = static_cast<std::uint32_t>(s);
    means[x] = static_cast<float>(static_cast<std::int32_t>(s >> 32)) * g.inv_count[n];
    means[cols + x] = static_cast<float>(n);
  }
}

template <GradientMode M>
void unnormalisedNormal(const GradientRow& g, int u) {
  constexpr int K = windowChannels(M);
  const int r = g.radius[u], cols = g.cols, v = g.v;
  g.normal_x[u] = g.normal_y[u] = g.normal_z[u] = 0.0f;
  if (r == 0) return;
  cacheWindow<M>(g, g.mean_here, g.radius_here, u - 1, v, r);
  cacheWindow<M>(g, g.mean_here, g.radius_here, u + 1, v, r);
  cacheWindow<M>(g, g.mean_above, g.radius_above, u, v - 1, r);
  cacheWindow<M>(g, g.mean_below, g.radius_below, u, v + 1, r);
  // Channel k of the left, right, up and down windows.
  auto left = [&](int k) { return g.mean_here[k * cols + u - 1]; };
  auto right = [&](int k) { return g.mean_here[k * cols + u + 1]; };
  auto up = [&](int k) { return g.mean_above[k * cols + u]; };
  auto down = [&](int k) { return g.mean_below[k * cols + u]; };
  const float min_n = static_cast<float>(g.min_count[r]);
  if (std::min(std::min(left(K - 1), right(K - 1)), std::min(up(K - 1), down(K - 1))) < min_n)
    return;
  if constexpr (M == GradientMode::k3dGradient) {
    // Differences of the means of the four windows: the averaged tangents (for a plane the mean
    // of 3D points lies on the plane); the normal is h x t.
    const float hx = right(0) - left(0), hy = right(1) - left(1), hz = right(2) - left(2);
    const float tx = down(0) - up(0), ty = down(1) - up(1), tz = down(2) - up(2);
    g.normal_x[u] = hy * tz - hz * ty;
    g.normal_y[u] = hz * tx - hx * tz;
    g.normal_z[u] = hx * ty - hy * tx;
  } else {
    const float zl = left(0), zr = right(0), zu = up(0), zd = down(0);
    // Depth derivatives per pixel and the pinhole model: for z(u, v) the (unnormalised) normal
    // facing the camera is (fx zu, fy zv, -(z + (u-cx) zu + (v-cy) zv)).
    const float du = 0.5f * (zr - zl), dv = 0.5f * (zd - zu);
    const float zm = 0.25f * (zl + zr + zu + zd);
    g.normal_x[u] = g.fx * du;
    g.normal_y[u] = g.fy * dv;
    g.normal_z[u] =
        -(zm + (static_cast<float>(u) - g.cx) * du + (static_cast<float>(v) - g.cy) * dv);
  }
}

void normalizePixels(const GradientRow& g, int begin, int end) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  for (int u = begin; u < end; ++u) {
    const float x = g.normal_x[u], y = g.normal_y[u], z = g.normal_z[u];
    const float len2 = x * x + y * y + z * z;
    float* o = g.out + 3 * u;
    if (!(len2 > 1e-20f)) {
      o[0] = o[1] = o[2] = kNaN;
      continue;
    }
    float k = 1.0f / std::sqrt(len2);
    if (x * (static_cast<float>(u) - g.cx) * g.ifx + y * g.ray_y + z > 0.0f) k = -k;
    o[0] = x * k;
    o[1] = y * k;
    o[2] = z * k;
  }
}

template void cacheWindow<GradientMode::k3dGradient>(const GradientRow&, float*, int*, int, int,
                                                     int);
template void cacheWindow<GradientMode::kDepthChange>(const GradientRow&, float*, int*, int, int,
                                                      int);
template void unnormalisedNormal<GradientMode::k3dGradient>(const GradientRow&, int);
template void unnormalisedNormal<GradientMode::kDepthChange>(const GradientRow&, int);

}  // namespace shapesense::detail
