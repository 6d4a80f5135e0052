#include "normals/covariance_estimator.h"

#include <algorithm>
#include <cmath>

#include "normals/normal_input.h"
#include "normals/step_map.h"

namespace shapesense::detail {
namespace {

constexpr int kMoments = 9;  // x, y, z, xx, xy, xz, yy, yz, zz

bool validZ(float z) { return z > 0.0f; }  // NaN compares false

// The integral images of the valid count (uint32, wrapping: window sums stay exact) and of the
// nine moments (double), one row and one column of zeros first.
void integrateMoments(const cv::Mat& points, CovarianceBuffers& b) {
  const int rows = points.rows, cols = points.cols;
  const std::size_t cstride = static_cast<std::size_t>(cols + 1);
  const std::size_t mstride = cstride * kMoments;
  b.count.resize(static_cast<std::size_t>(rows + 1) * cstride);
  std::fill(b.count.begin(), b.count.begin() + cstride, 0u);
  b.moments.resize(static_cast<std::size_t>(rows + 1) * mstride);
  std::fill(b.moments.begin(), b.moments.begin() + mstride, 0.0);
  for (int v = 0; v < rows; ++v) {
    const auto* p = points.ptr<cv::Vec3f>(v);
    std::uint32_t* crow = b.count.data() + (v + 1) * cstride;
    const std::uint32_t* cabove = crow - cstride;
    std::uint32_t cacc = 0;
    crow[0] = 0;
    for (int u = 0; u < cols; ++u) {
      cacc += static_cast<std::uint32_t>(validZ(p[u][2]));
      crow[u + 1] = cabove[u + 1] + cacc;
    }
    double* row = b.moments.data() + (v + 1) * mstride;
    const double* above = row - mstride;
    double acc[kMoments] = {};
    for (int k = 0; k < kMoments; ++k) row[k] = 0.0;
    for (int u = 0; u < cols; ++u) {
      const float zf = p[u][2];
      if (validZ(zf)) {
        const double x = p[u][0], y = p[u][1], z = zf;
        acc[0] += x;
        acc[1] += y;
        acc[2] += z;
        acc[3] += x * x;
        acc[4] += x * y;
        acc[5] += x * z;
        acc[6] += y * y;
        acc[7] += y * z;
        acc[8] += z * z;
      }
      double* out = row + (u + 1) * kMoments;
      const double* a = above + (u + 1) * kMoments;
      for (int k = 0; k < kMoments; ++k) out[k] = a[k] + acc[k];
    }
  }
}

// The smallest eigenvector of the covariance of a window (moment sums m, n points), as a unit
// vector. Smallest eigenvector of C = dominant eigenvector of adj(C) (eigenvalues l2*l3, l1*l3,
// l1*l2): power iteration converges with ratio l1/l2, i.e. in one or two steps on a planar
// patch. It starts from the viewing ray (visible surfaces face the camera).
cv::Vec3f smallestEigenvector(const double* m, double n) {
  const double inv = 1.0 / n;
  const double mx = m[0] * inv, my = m[1] * inv, mz = m[2] * inv;
  const double cxx = m[3] * inv - mx * mx, cxy = m[4] * inv - mx * my, cxz = m[5] * inv - mx * mz;
  const double cyy = m[6] * inv - my * my, cyz = m[7] * inv - my * mz, czz = m[8] * inv - mz * mz;
  const double a00 = cyy * czz - cyz * cyz, a01 = cxz * cyz - cxy * czz,
               a02 = cxy * cyz - cxz * cyy;
  const double a11 = cxx * czz - cxz * cxz, a12 = cxy * cxz - cxx * cyz,
               a22 = cxx * cyy - cxy * cxy;
  // The iterates are normalised once at the end (a direction is all that is needed, and the
  // range of double covers three products by adj(C)), not at every step.
  double ex = -mx, ey = -my, ez = -mz;
  for (int it = 0; it < 3; ++it) {
    const double tx = a00 * ex + a01 * ey + a02 * ez;
    const double ty = a01 * ex + a11 * ey + a12 * ez;
    const double tz = a02 * ex + a12 * ey + a22 * ez;
    if (!(tx * tx + ty * ty + tz * tz > 0.0)) break;
    ex = tx;
    ey = ty;
    ez = tz;
  }
  const double inv_len = 1.0 / std::sqrt(ex * ex + ey * ey + ez * ez);
  return {static_cast<float>(ex * inv_len), static_cast<float>(ey * inv_len),
          static_cast<float>(ez * inv_len)};
}

// The window-radius rule of the covariance mode (its window is centred on the pixel).
struct CovarianceWindows {
  float base_r;
  bool scale_r;
  int min_r, max_r;
  float min_frac;
};

// The normal of pixel (u, v) with point p, or false where it has none: the range-scaled window,
// clipped by the image border and the nearest step mark, with enough valid points.
bool pixelNormal(const CovarianceWindows& rule, const CovarianceBuffers& b, int rows, int cols,
                 int u, int v, const cv::Vec3f& p, std::int16_t step_distance, cv::Vec3f& normal) {
  const float z = p[2];
  int r = static_cast<int>(rule.base_r * (rule.scale_r ? z : 1.0f) + 0.5f);
  r = std::min({std::clamp(r, rule.min_r, rule.max_r), std::min(v, rows - 1 - v),
                std::min(u, cols - 1 - u)});
  r = std::min(r, step_distance - 1);  // the largest window that holds no step mark
  if (r < rule.min_r) return false;
  const int w = 2 * r + 1;
  const std::size_t cstride = static_cast<std::size_t>(cols + 1);
  const std::uint32_t* ca = b.count.data() + (v - r) * cstride + (u - r);
  const double n = static_cast<int>(ca[w * (cstride + 1)] - ca[w] - ca[w * cstride] + ca[0]);
  if (n < std::max(6.0f, rule.min_frac * static_cast<float>(w * w))) return false;
  const std::size_t mstride = cstride * kMoments;
  const double* a = b.moments.data() + (v - r) * mstride + (u - r) * kMoments;
  const double* bb = a + w * kMoments;
  const double* c = a + w * mstride;
  const double* d = c + w * kMoments;
  double m[kMoments];  // window sums of the moments
  for (int k = 0; k < kMoments; ++k) m[k] = d[k] - bb[k] - c[k] + a[k];
  const cv::Vec3f e = smallestEigenvector(m, n);
  const float len2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  if (!(len2 > 1e-20f)) return false;
  float s = 1.0f / std::sqrt(len2);
  if (e[0] * p[0] + e[1] * p[1] + e[2] * z > 0.0f) s = -s;  // face the camera
  normal = cv::Vec3f(e[0] * s, e[1] * s, e[2] * s);
  return true;
}

}  // namespace

void estimateCovarianceNormals(const NormalParams& params, NormalWorkspace& work,
                               cv::Mat& normals) {
  NormalInput& input = work.input;
  buildPoints(input);  // the moments need x and y too
  integrateMoments(input.points, work.covariance);
  CovarianceWindows rule;
  rule.base_r = static_cast<float>(params.smoothing_radius_px);
  rule.scale_r = params.depth_dependent_smoothing;
  rule.min_r = std::max(1, params.min_radius_px);
  rule.max_r = std::max(rule.min_r, params.max_radius_px);
  rule.min_frac = static_cast<float>(params.min_valid_fraction);
  computeStepDistance(std::min(rule.max_r + 3, 30000), work.steps);  // any cap > max_r + 1 is far
  const int rows = input.rows, cols = input.cols;
  for (int v = 0; v < rows; ++v) {
    const auto* p = input.points.ptr<cv::Vec3f>(v);
    const std::int16_t* dist = work.steps.distance.data() + static_cast<std::size_t>(v) * cols;
    auto* out = normals.ptr<cv::Vec3f>(v);
    for (int u = 0; u < cols; ++u) {
      if (!validZ(p[u][2])) continue;
      cv::Vec3f n;
      if (pixelNormal(rule, work.covariance, rows, cols, u, v, p[u], dist[u], n)) out[u] = n;
    }
  }
}

}  // namespace shapesense::detail
