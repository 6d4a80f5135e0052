#include "shapesense/core/normals.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace shapesense {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

inline bool validZ(float z) { return z > 0.0f; }  // NaN compares false

// Half-open rectangle sum of channel block `k0..k0+n` from an interleaved integral image.
struct IntegralView {
  const double* data;
  int stride;  // elements per integral row = (cols+1)*K
  int K;
  const double* at(int v, int u) const { return data + static_cast<std::ptrdiff_t>(v) * stride + u * K; }
};

}  // namespace

// Marks depth steps (between neighbouring valid pixels, also across short runs of holes) and
// computes the chessboard distance to the nearest step: a (2r+1)^2 window centred on a pixel
// with distance > r contains no step, which is exactly what the window clipping needs.
void NormalEstimator::buildStepDistance(const CameraIntrinsics& /*intrinsics*/) {
  const int rows = points_.rows, cols = points_.cols;
  dist_.create(rows, cols, CV_8UC1);
  dist_.setTo(255);
  const float factor = static_cast<float>(params_.max_depth_change_factor);
  const float noise_k = static_cast<float>(params_.depth_change_noise_steps *
                                           params_.noise.disparity_step_px /
                                           params_.noise.focal_baseline_px_m);
  const int max_gap = std::max(0, params_.max_gap_px);
  auto threshold = [&](float z, int gap) {
    return std::max(factor * z * static_cast<float>(gap + 1), noise_k * z * z);
  };
  last_z_.assign(cols, 0.0f);
  last_v_.assign(cols, -1000000);
  for (int v = 0; v < rows; ++v) {
    const auto* p = points_.ptr<cv::Vec3f>(v);
    auto* d = dist_.ptr<std::uint8_t>(v);
    float prev_z = 0.0f;
    int prev_u = -1000000;
    for (int u = 0; u < cols; ++u) {
      const float z = p[u][2];
      if (!validZ(z)) continue;
      // horizontal: compare with the previous valid pixel of this row
      const int gap_h = u - prev_u - 1;
      if (gap_h <= max_gap && std::fabs(z - prev_z) > threshold(std::min(z, prev_z), gap_h)) {
        d[prev_u] = 0;
      }
      prev_z = z;
      prev_u = u;
      // vertical: compare with the previous valid pixel of this column
      const int gap_v = v - last_v_[u] - 1;
      if (gap_v <= max_gap &&
          std::fabs(z - last_z_[u]) > threshold(std::min(z, last_z_[u]), gap_v)) {
        dist_.ptr<std::uint8_t>(last_v_[u])[u] = 0;
      }
      last_z_[u] = z;
      last_v_[u] = v;
    }
  }
  // Two-pass chessboard distance transform (saturating at 255).
  for (int v = 0; v < rows; ++v) {
    auto* d = dist_.ptr<std::uint8_t>(v);
    const auto* up = v > 0 ? dist_.ptr<std::uint8_t>(v - 1) : nullptr;
    for (int u = 0; u < cols; ++u) {
      int m = d[u];
      if (m == 0) continue;
      if (u > 0) m = std::min(m, d[u - 1] + 1);
      if (up) {
        m = std::min(m, up[u] + 1);
        if (u > 0) m = std::min(m, up[u - 1] + 1);
        if (u + 1 < cols) m = std::min(m, up[u + 1] + 1);
      }
      d[u] = static_cast<std::uint8_t>(std::min(m, 255));
    }
  }
  for (int v = rows - 1; v >= 0; --v) {
    auto* d = dist_.ptr<std::uint8_t>(v);
    const auto* dn = v + 1 < rows ? dist_.ptr<std::uint8_t>(v + 1) : nullptr;
    for (int u = cols - 1; u >= 0; --u) {
      int m = d[u];
      if (m == 0) continue;
      if (u + 1 < cols) m = std::min(m, d[u + 1] + 1);
      if (dn) {
        m = std::min(m, dn[u] + 1);
        if (u > 0) m = std::min(m, dn[u - 1] + 1);
        if (u + 1 < cols) m = std::min(m, dn[u + 1] + 1);
      }
      d[u] = static_cast<std::uint8_t>(std::min(m, 255));
    }
  }
}

// Interleaved integral image of K channels: K=2 (n, z), K=4 (n, x, y, z),
// K=10 (n, x, y, z, xx, xy, xz, yy, yz, zz). Invalid pixels contribute nothing.
template <int K>
void NormalEstimator::buildIntegral() {
  const int rows = points_.rows, cols = points_.cols;
  const int stride = (cols + 1) * K;
  integral_.resize(static_cast<std::size_t>(rows + 1) * stride);
  std::fill(integral_.begin(), integral_.begin() + stride, 0.0);
  for (int v = 0; v < rows; ++v) {
    const auto* p = points_.ptr<cv::Vec3f>(v);
    const double* above = integral_.data() + static_cast<std::size_t>(v) * stride;
    double* row = integral_.data() + static_cast<std::size_t>(v + 1) * stride;
    double acc[K] = {};
    for (int k = 0; k < K; ++k) row[k] = 0.0;
    for (int u = 0; u < cols; ++u) {
      const float z = p[u][2];
      if (validZ(z)) {
        const double x = p[u][0], y = p[u][1], zz = z;
        acc[0] += 1.0;
        if constexpr (K == 2) {
          acc[1] += zz;
        } else {
          acc[1] += x;
          acc[2] += y;
          acc[3] += zz;
          if constexpr (K == 10) {
            acc[4] += x * x;
            acc[5] += x * y;
            acc[6] += x * zz;
            acc[7] += y * y;
            acc[8] += y * zz;
            acc[9] += zz * zz;
          }
        }
      }
      double* out = row + (u + 1) * K;
      const double* a = above + (u + 1) * K;
      for (int k = 0; k < K; ++k) out[k] = a[k] + acc[k];
    }
  }
}

void NormalEstimator::compute(const cv::Mat& input, const CameraIntrinsics& intr, cv::Mat& normals) {
  CV_Assert(input.type() == CV_16UC1 || input.type() == CV_32FC3);
  const int rows = input.rows, cols = input.cols;
  // 1. Organised points.
  if (input.type() == CV_16UC1) {
    points_.create(rows, cols, CV_32FC3);
    const float inv_fx = static_cast<float>(1.0 / intr.fx), inv_fy = static_cast<float>(1.0 / intr.fy);
    const float cx = static_cast<float>(intr.cx), cy = static_cast<float>(intr.cy);
    for (int v = 0; v < rows; ++v) {
      const auto* d = input.ptr<std::uint16_t>(v);
      auto* p = points_.ptr<cv::Vec3f>(v);
      const float ry = (static_cast<float>(v) - cy) * inv_fy;
      for (int u = 0; u < cols; ++u) {
        if (d[u] == 0) {
          p[u] = cv::Vec3f(kNaN, kNaN, kNaN);
        } else {
          const float z = static_cast<float>(d[u]) * 0.001f;
          p[u] = cv::Vec3f((static_cast<float>(u) - cx) * inv_fx * z, ry * z, z);
        }
      }
    }
  } else {
    input.copyTo(points_);
  }
  normals.create(rows, cols, CV_32FC3);

  // 2. Distance to depth steps and integral images.
  buildStepDistance(intr);
  const NormalMethod method = params_.method;
  int K = 4;
  if (method == NormalMethod::kCovariance) {
    K = 10;
    buildIntegral<10>();
  } else if (method == NormalMethod::kAverage3dGradient) {
    buildIntegral<4>();
  } else {
    K = 2;
    buildIntegral<2>();
  }
  const IntegralView I{integral_.data(), (cols + 1) * K, K};

  const float base_r = static_cast<float>(params_.smoothing_radius_px);
  const bool scale_r = params_.depth_dependent_smoothing;
  const int min_r = std::max(1, params_.min_radius_px);
  const int max_r = std::max(min_r, params_.max_radius_px);
  const double min_frac = params_.min_valid_fraction;
  const double fx = intr.fx, fy = intr.fy, cx = intr.cx, cy = intr.cy;

  // Sum of the K channels over the clamped window [u-r, u+r] x [v-r, v+r] centred at (uc, vc).
  auto windowSum = [&](int uc, int vc, int r, double* s) {
    const int u0 = std::max(uc - r, 0), u1 = std::min(uc + r + 1, cols);
    const int v0 = std::max(vc - r, 0), v1 = std::min(vc + r + 1, rows);
    const double* a = I.at(v0, u0);
    const double* b = I.at(v0, u1);
    const double* c = I.at(v1, u0);
    const double* d = I.at(v1, u1);
    for (int k = 0; k < K; ++k) s[k] = d[k] - b[k] - c[k] + a[k];
    return (u1 - u0) * (v1 - v0);
  };

  for (int v = 0; v < rows; ++v) {
    const auto* p = points_.ptr<cv::Vec3f>(v);
    const auto* dist = dist_.ptr<std::uint8_t>(v);
    auto* n_out = normals.ptr<cv::Vec3f>(v);
    for (int u = 0; u < cols; ++u) {
      n_out[u] = cv::Vec3f(kNaN, kNaN, kNaN);
      const float z = p[u][2];
      if (!validZ(z)) continue;
      int r = static_cast<int>(base_r * (scale_r ? z : 1.0f) + 0.5f);
      r = std::clamp(r, min_r, max_r);
      r = std::min(r, static_cast<int>(dist[u]) - 1);
      if (r < min_r) continue;
      // Windows must stay inside the image so that gradients are not biased by clamping.
      if (u - r - 1 < 0 || v - r - 1 < 0 || u + r + 1 >= cols || v + r + 1 >= rows) continue;

      double nx, ny, nz;
      if (method == NormalMethod::kCovariance) {
        double s[10];
        const int area = windowSum(u, v, r, s);
        const double n = s[0];
        if (n < std::max(6.0, min_frac * area)) continue;
        const double inv = 1.0 / n;
        const double mx = s[1] * inv, my = s[2] * inv, mz = s[3] * inv;
        const double cxx = s[4] * inv - mx * mx, cxy = s[5] * inv - mx * my, cxz = s[6] * inv - mx * mz;
        const double cyy = s[7] * inv - my * my, cyz = s[8] * inv - my * mz, czz = s[9] * inv - mz * mz;
        // Smallest eigenvector of C = dominant eigenvector of adj(C) (eigenvalues l2*l3, l1*l3,
        // l1*l2): power iteration converges with ratio l1/l2, i.e. in one or two steps on a
        // planar patch. Start from the viewing ray (visible surfaces face the camera).
        const double a00 = cyy * czz - cyz * cyz, a01 = cxz * cyz - cxy * czz, a02 = cxy * cyz - cxz * cyy;
        const double a11 = cxx * czz - cxz * cxz, a12 = cxy * cxz - cxx * cyz, a22 = cxx * cyy - cxy * cxy;
        double ex = -mx, ey = -my, ez = -mz;
        for (int it = 0; it < 3; ++it) {
          const double tx = a00 * ex + a01 * ey + a02 * ez;
          const double ty = a01 * ex + a11 * ey + a12 * ez;
          const double tz = a02 * ex + a12 * ey + a22 * ez;
          const double len = std::sqrt(tx * tx + ty * ty + tz * tz);
          if (!(len > 0.0)) break;
          ex = tx / len;
          ey = ty / len;
          ez = tz / len;
        }
        nx = ex;
        ny = ey;
        nz = ez;
      } else {
        // Means of the four windows centred one pixel left/right/up/down; their differences are
        // the averaged tangents (for a plane the mean of 3D points lies on the plane).
        double sl[4], sr[4], su[4], sd[4];
        const int area = windowSum(u - 1, v, r, sl);
        windowSum(u + 1, v, r, sr);
        windowSum(u, v - 1, r, su);
        windowSum(u, v + 1, r, sd);
        const double min_n = std::max(4.0, min_frac * area);
        if (sl[0] < min_n || sr[0] < min_n || su[0] < min_n || sd[0] < min_n) continue;
        const double il = 1.0 / sl[0], ir = 1.0 / sr[0], iu = 1.0 / su[0], id = 1.0 / sd[0];
        if (method == NormalMethod::kAverage3dGradient) {
          const double hx = sr[1] * ir - sl[1] * il, hy = sr[2] * ir - sl[2] * il, hz = sr[3] * ir - sl[3] * il;
          const double vx = sd[1] * id - su[1] * iu, vy = sd[2] * id - su[2] * iu, vz = sd[3] * id - su[3] * iu;
          nx = hy * vz - hz * vy;
          ny = hz * vx - hx * vz;
          nz = hx * vy - hy * vx;
        } else {
          // Depth derivatives per pixel and the pinhole model: for z(u, v) the (unnormalised)
          // normal facing the camera is (fx zu, fy zv, -(z + (u-cx) zu + (v-cy) zv)).
          const double zl = sl[1] * il, zr = sr[1] * ir, zu_ = su[1] * iu, zd = sd[1] * id;
          const double du = 0.5 * (zr - zl), dv = 0.5 * (zd - zu_);
          const double zm = 0.25 * (zl + zr + zu_ + zd);
          nx = fx * du;
          ny = fy * dv;
          nz = -(zm + (u - cx) * du + (v - cy) * dv);
        }
      }
      const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
      if (!(len > 1e-12)) continue;
      double s = 1.0 / len;
      if (nx * p[u][0] + ny * p[u][1] + nz * z > 0.0) s = -s;  // face the camera
      n_out[u] = cv::Vec3f(static_cast<float>(nx * s), static_cast<float>(ny * s), static_cast<float>(nz * s));
    }
  }
}

cv::Mat computeNormals(const cv::Mat& points_or_depth, const CameraIntrinsics& intrinsics,
                       const NormalParams& params) {
  NormalEstimator estimator(params);
  cv::Mat normals;
  estimator.compute(points_or_depth, intrinsics, normals);
  return normals;
}

}  // namespace shapesense
