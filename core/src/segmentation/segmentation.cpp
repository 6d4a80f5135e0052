#include "shapesense/core/segmentation/segmentation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <vector>

#include <opencv2/imgproc.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace shapesense {

std::string_view formatSegmentationMethod(SegmentationMethod method) {
  switch (method) {
    case SegmentationMethod::kDepthStep:
      return "depth_step";
    case SegmentationMethod::kNormalEdges:
      return "normal_edges";
    case SegmentationMethod::kFused:
      return "fused";
    case SegmentationMethod::kPlanePrediction:
      return "plane_prediction";
    case SegmentationMethod::kTiledRansac:
      return "tiled_ransac";
  }
  return "unknown";
}

std::optional<SegmentationMethod> parseSegmentationMethod(std::string_view name) {
  for (auto m : {SegmentationMethod::kDepthStep, SegmentationMethod::kNormalEdges,
                 SegmentationMethod::kFused, SegmentationMethod::kPlanePrediction,
                 SegmentationMethod::kTiledRansac}) {
    if (formatSegmentationMethod(m) == name) return m;
  }
  return std::nullopt;
}

namespace {

constexpr std::uint8_t kNoDepth = 255;  // edge strength of pixels without depth

// Inverse-depth size (1/m) of one sensor quantisation step: constant over range for a
// disparity sensor (depthStep(z) / z^2).
double inverseDepthStep(const KinectNoiseModel& noise) {
  return noise.disparity_step_px / noise.focal_baseline_px_m;
}

struct Working {
  cv::Mat depth;  // CV_16UC1 mm at working resolution
  CameraIntrinsics intr;
  int ds = 1;
};

#if defined(__SSE2__)
// makeWorking's 2x2 reduction of output pixels u..u+3 (input columns 2u..2u+7 of rows a and b),
// with the same values as its scalar loop: 32-bit lanes (SSE2 has no unsigned 16-bit min or
// compare), the same float products for the limit, and the rounded mean (sum + n/2) / n as a
// float division, which is exact here (sum < 2^19 and n <= 4: the quotient never rounds to the
// next integer).
void reduceBlocks4(const std::uint16_t* a, const std::uint16_t* b, int u, float k,
                   std::uint16_t* o) {
  const __m128i low16 = _mm_set1_epi32(0xFFFF), zero = _mm_setzero_si128();
  const __m128i ra = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a + 2 * u));
  const __m128i rb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + 2 * u));
  const __m128i q[4] = {_mm_and_si128(ra, low16), _mm_srli_epi32(ra, 16), _mm_and_si128(rb, low16),
                        _mm_srli_epi32(rb, 16)};
  __m128i none[4];  // no reading
  auto min32 = [](__m128i x, __m128i y) {
    const __m128i x_greater = _mm_cmpgt_epi32(x, y);
    return _mm_or_si128(_mm_and_si128(x_greater, y), _mm_andnot_si128(x_greater, x));
  };
  __m128i mn = low16;  // as the scalar loop: 0xFFFF means no reading below it
  for (int i = 0; i < 4; ++i) {
    none[i] = _mm_cmpeq_epi32(q[i], zero);
    mn = min32(mn, _mm_or_si128(q[i], _mm_and_si128(none[i], low16)));
  }
  const __m128 mnf = _mm_cvtepi32_ps(mn);
  const __m128i lim = _mm_add_epi32(
      _mm_add_epi32(mn, _mm_cvttps_epi32(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(k), mnf), mnf))),
      _mm_set1_epi32(1));
  __m128i sum = zero, minus_n = zero;
  for (int i = 0; i < 4; ++i) {
    const __m128i out = _mm_or_si128(none[i], _mm_cmpgt_epi32(q[i], lim));
    sum = _mm_add_epi32(sum, _mm_andnot_si128(out, q[i]));
    minus_n = _mm_add_epi32(minus_n, _mm_andnot_si128(out, _mm_set1_epi32(-1)));
  }
  const __m128i n = _mm_sub_epi32(zero, minus_n);
  const __m128 mean =
      _mm_div_ps(_mm_cvtepi32_ps(_mm_add_epi32(sum, _mm_srli_epi32(n, 1))), _mm_cvtepi32_ps(n));
  // 0 where no reading (there n = 0 and the quotient is NaN).
  const __m128i value = _mm_andnot_si128(_mm_cmpeq_epi32(mn, low16), _mm_cvttps_epi32(mean));
  // uint16 from int32 <= 0xFFFF: shifted into the signed range for the saturating pack, and back.
  const __m128i bias = _mm_set1_epi32(0x8000);
  const __m128i packed = _mm_packs_epi32(_mm_sub_epi32(value, bias), zero);
  _mm_storel_epi64(reinterpret_cast<__m128i*>(o + u),
                   _mm_add_epi16(packed, _mm_set1_epi16(static_cast<short>(0x8000))));
}
#endif

// Reduces the depth image by `ds` (1 or 2). A 2x2 block keeps the mean of its valid pixels that
// are within 3 quantisation steps of the nearest one, so that blocks on a depth step take the
// foreground instead of a mixed depth that belongs to neither surface.
Working makeWorking(const cv::Mat& depth, const CameraIntrinsics& intr, const RegionParams& rp) {
  CV_Assert(depth.type() == CV_16UC1);
  Working w;
  w.ds = std::clamp(rp.downsample, 1, 2);
  // An image with a single row or column has no 2x2 block to reduce.
  if (depth.rows < 2 || depth.cols < 2) w.ds = 1;
  if (w.ds == 1) {
    w.depth = depth;
    w.intr = intr;
    return w;
  }
  const int rows = depth.rows / 2, cols = depth.cols / 2;
  w.depth.create(rows, cols, CV_16UC1);
  const float k =
      static_cast<float>(3.0 * rp.noise.disparity_step_px / rp.noise.focal_baseline_px_m * 1e-3);
  for (int v = 0; v < rows; ++v) {
    const auto* a = depth.ptr<std::uint16_t>(2 * v);
    const auto* b = depth.ptr<std::uint16_t>(2 * v + 1);
    auto* o = w.depth.ptr<std::uint16_t>(v);
    int u = 0;
#if defined(__SSE2__)
    for (; u + 4 <= cols; u += 4) reduceBlocks4(a, b, u, k, o);
#endif
    for (; u < cols; ++u) {
      const std::uint16_t q[4] = {a[2 * u], a[2 * u + 1], b[2 * u], b[2 * u + 1]};
      unsigned mn = 0xFFFF;
      for (auto x : q)
        if (x != 0 && x < mn) mn = x;
      if (mn == 0xFFFF) {
        o[u] = 0;
        continue;
      }
      const unsigned lim =
          mn + static_cast<unsigned>(k * static_cast<float>(mn) * static_cast<float>(mn)) + 1;
      unsigned sum = 0, n = 0;
      for (auto x : q) {
        if (x != 0 && x <= lim) {
          sum += x;
          ++n;
        }
      }
      o[u] = static_cast<std::uint16_t>((sum + n / 2) / n);
    }
  }
  w.intr = intr;
  w.intr.fx = intr.fx / 2.0;
  w.intr.fy = intr.fy / 2.0;
  w.intr.cx = (intr.cx - 0.5) / 2.0;
  w.intr.cy = (intr.cy - 0.5) / 2.0;
  w.intr.width = cols;
  w.intr.height = rows;
  return w;
}

#if defined(__SSE2__)
// depthStepEdges for pixels u..u+7 of row v, whose windows lie inside the row (u - r >= 0,
// u + 7 + r < cols): the same counts, all offsets accumulated in one register. SSE2 has no
// unsigned 16-bit compare, so with saturating subtraction: |x - y| = (x -sat y) | (y -sat x), and
// |x - y| > t iff |x - y| -sat t != 0. The register counts the misses (-1 per offset where the
// neighbour has no depth or does not differ), subtracted from the offsets inside the image.
template <int R>
void stepCount8(const std::uint16_t* dp, const std::uint16_t* const* window_rows,
                const std::uint16_t* const* thr_rows, int u, int offsets, std::uint8_t* e) {
  constexpr int r = R;  // a template argument: the offset loops unroll
  auto load = [](const std::uint16_t* p) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
  };
  const __m128i zero = _mm_setzero_si128();
  const __m128i x = load(dp + u);
  __m128i t[R];
  for (int k = 0; k < R; ++k) t[k] = load(thr_rows[k] + u);
  __m128i minus_misses = zero;
  for (int dv = -r; dv <= r; ++dv) {
    const std::uint16_t* dq = window_rows[dv + r];
    if (dq == nullptr) continue;
    for (int du = -r; du <= r; ++du) {
      if (du == 0 && dv == 0) continue;
      const __m128i tr = t[std::max(std::abs(du), std::abs(dv)) - 1];
      const __m128i y = load(dq + u + du);
      const __m128i diff = _mm_or_si128(_mm_subs_epu16(x, y), _mm_subs_epu16(y, x));
      const __m128i miss =
          _mm_or_si128(_mm_cmpeq_epi16(_mm_subs_epu16(diff, tr), zero), _mm_cmpeq_epi16(y, zero));
      minus_misses = _mm_add_epi16(minus_misses, miss);
    }
  }
  const __m128i count = _mm_add_epi16(_mm_set1_epi16(static_cast<short>(offsets)), minus_misses);
  // kNoDepth (255) where the centre has no depth: or with the all-ones byte mask.
  const __m128i no_depth = _mm_cmpeq_epi16(x, zero);
  const __m128i out = _mm_or_si128(_mm_packus_epi16(count, zero), _mm_packs_epi16(no_depth, zero));
  _mm_storel_epi64(reinterpret_cast<__m128i*>(e + u), out);
}
#endif

// Depth-step edge strength: per pixel, the number of valid neighbours in the window whose depth
// differs by more than the ring's threshold. CV_8UC1, kNoDepth where there is no depth.
cv::Mat depthStepEdges(const Working& w, const DepthStepParams& p, const KinectNoiseModel& noise) {
  const cv::Mat& d = w.depth;
  const int rows = d.rows, cols = d.cols;
  const int r = std::clamp(p.window_radius, 1, 7);
  cv::Mat edges(rows, cols, CV_8UC1);
  // Per-pixel threshold of each ring (Chebyshev distance 1..r), uint16 mm, so that the counts
  // below are uint16 compares, eight pixels per SSE2 step (stepCount8).
  std::vector<cv::Mat> thr(r);
  for (auto& t : thr) t.create(rows, cols, CV_16UC1);
  const float step_k = static_cast<float>(p.noise_steps * noise.disparity_step_px /
                                          noise.focal_baseline_px_m * 1e-3);
  const float slope = static_cast<float>(p.slope_factor * w.ds);
  const float min_t = static_cast<float>(p.min_threshold_mm);
  for (int v = 0; v < rows; ++v) {
    const auto* dp = d.ptr<std::uint16_t>(v);
    for (int k = 0; k < r; ++k) {
      auto* t = thr[k].ptr<std::uint16_t>(v);
      const float ring = static_cast<float>(k + 1);
      for (int u = 0; u < cols; ++u) {
        const float z = static_cast<float>(dp[u]);
        const float th = std::max(min_t, step_k * z * z + slope * ring * z);
        t[u] = static_cast<std::uint16_t>(std::min(th, 65535.0f));
      }
    }
  }
  std::vector<const std::uint16_t*> window_rows(2 * r + 1);  // nullptr: outside the image
  std::vector<const std::uint16_t*> thr_rows(r);             // row v of each ring's thresholds
  for (int v = 0; v < rows; ++v) {
    const auto* dp = d.ptr<std::uint16_t>(v);
    for (int k = 0; k < r; ++k) thr_rows[k] = thr[k].ptr<std::uint16_t>(v);
    int offsets = 0;  // window offsets whose row is inside the image
    for (int dv = -r; dv <= r; ++dv) {
      const int vq = v + dv;
      const bool inside = vq >= 0 && vq < rows;
      window_rows[dv + r] = inside ? d.ptr<std::uint16_t>(vq) : nullptr;
      offsets += inside ? (dv == 0 ? 2 * r : 2 * r + 1) : 0;
    }
    auto* e = edges.ptr<std::uint8_t>(v);
    // One pixel, any column.
    auto pixel = [&](int u) {
      const std::uint16_t x = dp[u];
      int count = 0;
      for (int dv = -r; dv <= r; ++dv) {
        const std::uint16_t* dq = window_rows[dv + r];
        if (dq == nullptr) continue;
        for (int du = -r; du <= r; ++du) {
          const int uq = u + du;
          if ((du == 0 && dv == 0) || uq < 0 || uq >= cols) continue;
          const std::uint16_t y = dq[uq];
          const std::uint16_t diff = x > y ? x - y : y - x;
          const int ring = std::max(std::abs(du), std::abs(dv));
          count += (y != 0) & (diff > thr_rows[ring - 1][u]);
        }
      }
      e[u] = x == 0 ? kNoDepth : static_cast<std::uint8_t>(count);
    };
    // Columns whose window row lies inside the image go eight at a time (the last block
    // overlapping the one before: the same values are written twice), the first and last r one
    // at a time.
    int simd_begin = 0, simd_end = 0;
#if defined(__SSE2__)
    if (cols - 2 * r >= 8) {
      simd_begin = r;
      simd_end = cols - r;
      auto blocks = [&]<int R>() {
        for (int u = simd_begin;; u += 8) {
          u = std::min(u, simd_end - 8);
          stepCount8<R>(dp, window_rows.data(), thr_rows.data(), u, offsets, e);
          if (u == simd_end - 8) break;
        }
      };
      switch (r) {  // r <= 7
        case 1:
          blocks.template operator()<1>();
          break;
        case 2:
          blocks.template operator()<2>();
          break;
        case 3:
          blocks.template operator()<3>();
          break;
        case 4:
          blocks.template operator()<4>();
          break;
        case 5:
          blocks.template operator()<5>();
          break;
        case 6:
          blocks.template operator()<6>();
          break;
        default:
          blocks.template operator()<7>();
          break;
      }
    }
#endif
    for (int u = 0; u < simd_begin; ++u) pixel(u);
    for (int u = std::max(simd_end, simd_begin); u < cols; ++u) pixel(u);
  }
  return edges;
}

// Roof-edge strength: the number of valid-depth neighbours whose normal differs by more than the
// angle. Normals are NaN next to depth steps (their windows must not straddle a step). Alone
// (`invalid_is_edge`), that band is the only trace of a step, so a neighbour with depth but no
// normal counts as differing and a centre without normal gets the full count. In the fused method
// the depth-step term detects the steps, so there the band counts nothing: otherwise the normal
// term saturates exactly where the depth term fires and the depth cue adds nothing.
cv::Mat normalEdges(const Working& w, const NormalEdgeParams& p, bool invalid_is_edge = true) {
  const int rows = w.depth.rows, cols = w.depth.cols;
  NormalEstimator est(p.normals);
  cv::Mat normals;
  est.compute(w.depth, w.intr, normals);
  const int r = std::clamp(p.window_radius, 1, 7);
  const float cos_t = static_cast<float>(std::cos(p.max_angle_deg * CV_PI / 180.0));
  const int full = (2 * r + 1) * (2 * r + 1) - 1;
  cv::Mat edges(rows, cols, CV_8UC1);
  std::vector<std::uint8_t> acc(cols);
  for (int v = 0; v < rows; ++v) {
    const auto* dp = w.depth.ptr<std::uint16_t>(v);
    const auto* np = normals.ptr<cv::Vec3f>(v);
    std::fill(acc.begin(), acc.end(), 0);
    for (int dv = -r; dv <= r; ++dv) {
      const int vq = v + dv;
      if (vq < 0 || vq >= rows) continue;
      const auto* dq = w.depth.ptr<std::uint16_t>(vq);
      const auto* nq = normals.ptr<cv::Vec3f>(vq);
      for (int du = -r; du <= r; ++du) {
        if (du == 0 && dv == 0) continue;
        const int u0 = std::max(0, -du), u1 = std::min(cols, cols - du);
        for (int u = u0; u < u1; ++u) {
          const cv::Vec3f& a = np[u];
          const cv::Vec3f& b = nq[u + du];
          const float dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
          // NaN dot products compare false: with invalid_is_edge they count, else they do not.
          acc[u] += static_cast<std::uint8_t>((dq[u + du] != 0) &
                                              (invalid_is_edge ? !(dot >= cos_t) : (dot < cos_t)));
        }
      }
    }
    auto* e = edges.ptr<std::uint8_t>(v);
    for (int u = 0; u < cols; ++u) {
      if (dp[u] == 0) {
        e[u] = kNoDepth;
      } else if (std::isnan(np[u][0])) {
        e[u] = invalid_is_edge ? static_cast<std::uint8_t>(full) : 0;
      } else {
        e[u] = acc[u];
      }
    }
  }
  return edges;
}

// Inverse depth (1/m, 0 where invalid) at working resolution.
cv::Mat inverseDepth(const cv::Mat& depth) {
  cv::Mat w(depth.size(), CV_32FC1);
  for (int v = 0; v < depth.rows; ++v) {
    const auto* d = depth.ptr<std::uint16_t>(v);
    auto* o = w.ptr<float>(v);
    for (int u = 0; u < depth.cols; ++u) o[u] = d[u] ? 1000.0f / static_cast<float>(d[u]) : 0.0f;
  }
  return w;
}

// Plane-prediction edge strength: planes are affine in inverse depth w = 1/z, so each neighbour's
// w is predicted from the centre's smoothed w and gradient; E = number of anomalous neighbours.
// With `short_edges`, also returns the dense-window count alone (for the fallback markers).
cv::Mat planePredictionEdges(const Working& w, const PlanePredictionParams& p,
                             const KinectNoiseModel& noise, cv::Mat* short_edges = nullptr) {
  const cv::Mat& d = w.depth;
  const int rows = d.rows, cols = d.cols;
  cv::Mat inv = inverseDepth(d);
  cv::Mat mask;
  cv::compare(d, 0, mask, cv::CMP_NE);
  mask.convertTo(mask, CV_32F, 1.0 / 255.0);
  const int s = std::max(0, p.smoothing_radius);
  cv::Mat inv_sum, cnt;
  cv::boxFilter(inv, inv_sum, CV_32F, cv::Size(2 * s + 1, 2 * s + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  cv::boxFilter(mask, cnt, CV_32F, cv::Size(2 * s + 1, 2 * s + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  // Smoothed inverse depth (0 where fewer than half the window is valid).
  cv::Mat sm(rows, cols, CV_32F);
  const float min_cnt = 0.5f * static_cast<float>((2 * s + 1) * (2 * s + 1));
  for (int v = 0; v < rows; ++v) {
    const float* a = inv_sum.ptr<float>(v);
    const float* c = cnt.ptr<float>(v);
    float* o = sm.ptr<float>(v);
    for (int u = 0; u < cols; ++u) o[u] = c[u] >= min_cnt ? a[u] / c[u] : 0.0f;
  }
  const int g = std::max(1, p.gradient_step);
  cv::Mat gx(rows, cols, CV_32F, cv::Scalar(0)), gy(rows, cols, CV_32F, cv::Scalar(0));
  const float inv2g = 1.0f / (2.0f * static_cast<float>(g));
  for (int v = 0; v < rows; ++v) {
    const float* c = sm.ptr<float>(v);
    const float* up = sm.ptr<float>(std::max(v - g, 0));
    const float* dn = sm.ptr<float>(std::min(v + g, rows - 1));
    float* ox = gx.ptr<float>(v);
    float* oy = gy.ptr<float>(v);
    for (int u = g; u < cols - g; ++u) {
      const float l = c[u - g], r = c[u + g];
      // One-sided difference where one side is missing keeps the prediction usable near holes.
      if (l > 0 && r > 0)
        ox[u] = (r - l) * inv2g;
      else if (l > 0 && c[u] > 0)
        ox[u] = (c[u] - l) / static_cast<float>(g);
      else if (r > 0 && c[u] > 0)
        ox[u] = (r - c[u]) / static_cast<float>(g);
      const float t = up[u], b = dn[u];
      if (t > 0 && b > 0 && v - g >= 0 && v + g < rows)
        oy[u] = (b - t) * inv2g;
      else if (t > 0 && c[u] > 0 && v - g >= 0)
        oy[u] = (c[u] - t) / static_cast<float>(g);
      else if (b > 0 && c[u] > 0 && v + g < rows)
        oy[u] = (b - c[u]) / static_cast<float>(g);
    }
  }
  const float thr = static_cast<float>(p.noise_steps * inverseDepthStep(noise));
  const float thr_long = static_cast<float>(p.long_noise_steps * inverseDepthStep(noise));
  // Offsets: the dense window, then the long-range ring (the outer ring of a grid with spacing
  // long_range / 2, i.e. 16 neighbours at distance long_range).
  struct Offset {
    int du, dv;
    bool long_range;
  };
  std::vector<Offset> offsets;
  const int r = std::clamp(p.window_radius, 1, 7);
  for (int dv = -r; dv <= r; ++dv)
    for (int du = -r; du <= r; ++du)
      if (du != 0 || dv != 0) offsets.push_back({du, dv, false});
  const int half = std::clamp(p.long_range, 0, 16) / 2;
  if (half > 0 && 2 * half > r) {
    for (int j = -2; j <= 2; ++j)
      for (int i = -2; i <= 2; ++i)
        if (std::max(std::abs(i), std::abs(j)) == 2) offsets.push_back({i * half, j * half, true});
  }
  cv::Mat edges(rows, cols, CV_8UC1);
  if (short_edges) short_edges->create(rows, cols, CV_8UC1);
  std::vector<std::uint8_t> acc_short(cols), acc_long(cols);
  std::vector<float> centre(cols);
  for (int v = 0; v < rows; ++v) {
    const float* wc = inv.ptr<float>(v);
    const float* smc = sm.ptr<float>(v);
    const float* gxp = gx.ptr<float>(v);
    const float* gyp = gy.ptr<float>(v);
    for (int u = 0; u < cols; ++u) centre[u] = smc[u] > 0 ? smc[u] : wc[u];
    std::fill(acc_short.begin(), acc_short.end(), 0);
    std::fill(acc_long.begin(), acc_long.end(), 0);
    for (const Offset& o : offsets) {
      const int vq = v + o.dv;
      if (vq < 0 || vq >= rows) continue;
      const float* wq = inv.ptr<float>(vq);
      const float fdu = static_cast<float>(o.du), fdv = static_cast<float>(o.dv);
      const float t = o.long_range ? thr_long : thr;
      std::uint8_t* acc = o.long_range ? acc_long.data() : acc_short.data();
      const int u0 = std::max(0, -o.du), u1 = std::min(cols, cols - o.du);
      for (int u = u0; u < u1; ++u) {
        const float pred = centre[u] + gxp[u] * fdu + gyp[u] * fdv;
        const float y = wq[u + o.du];
        acc[u] += static_cast<std::uint8_t>((y > 0.0f) & (std::fabs(y - pred) > t));
      }
    }
    auto* e = edges.ptr<std::uint8_t>(v);
    for (int u = 0; u < cols; ++u)
      e[u] = wc[u] == 0.0f ? kNoDepth : static_cast<std::uint8_t>(acc_short[u] + acc_long[u]);
    if (short_edges) {
      auto* es = short_edges->ptr<std::uint8_t>(v);
      for (int u = 0; u < cols; ++u) es[u] = wc[u] == 0.0f ? kNoDepth : acc_short[u];
    }
  }
  return edges;
}

cv::Mat edgeStrength(const Working& w, SegmentationMethod method,
                     const SegmentationParams& params) {
  switch (method) {
    case SegmentationMethod::kDepthStep:
      return depthStepEdges(w, params.depth_step, params.depth_step.region.noise);
    case SegmentationMethod::kNormalEdges:
      return normalEdges(w, params.normal_edges);
    case SegmentationMethod::kFused: {
      const auto& f = params.fused;
      cv::Mat ed = depthStepEdges(w, f.depth, f.region.noise);
      cv::Mat en = normalEdges(w, f.normal, f.invalid_normal_is_edge);
      cv::Mat e(ed.size(), CV_8UC1);
      const float wt = static_cast<float>(f.normal_weight);
      for (int v = 0; v < e.rows; ++v) {
        const auto* a = ed.ptr<std::uint8_t>(v);
        const auto* b = en.ptr<std::uint8_t>(v);
        auto* o = e.ptr<std::uint8_t>(v);
        for (int u = 0; u < e.cols; ++u) {
          o[u] = a[u] == kNoDepth
                     ? kNoDepth
                     : static_cast<std::uint8_t>(std::min(254.0f, a[u] + wt * b[u] + 0.5f));
        }
      }
      return e;
    }
    case SegmentationMethod::kPlanePrediction:
      return planePredictionEdges(w, params.plane_prediction, params.plane_prediction.region.noise);
    case SegmentationMethod::kTiledRansac:
      break;
  }
  return {};
}

const RegionParams& regionParams(SegmentationMethod method, const SegmentationParams& p) {
  switch (method) {
    case SegmentationMethod::kDepthStep:
      return p.depth_step.region;
    case SegmentationMethod::kNormalEdges:
      return p.normal_edges.region;
    case SegmentationMethod::kFused:
      return p.fused.region;
    case SegmentationMethod::kPlanePrediction:
      return p.plane_prediction.region;
    case SegmentationMethod::kTiledRansac:
      return p.tiled_ransac.region;
  }
  return p.depth_step.region;
}

// Markers: 4-connected components of pixels with edge <= max_edge, components below min_px
// dropped. With `fallback` (a second relief, e.g. plane prediction's dense window alone), its
// low-edge components that contain no marker pixel become markers too. CV_32SC1, 0 = unmarked.
// Returns the number of the largest label used.
int markersFromEdges(const cv::Mat& edges, int max_edge, int min_px, cv::Mat& markers,
                     const cv::Mat& fallback = {}) {
  cv::Mat mask = edges <= std::min(max_edge, 254);
  cv::Mat labels;
  const int n = cv::connectedComponents(mask, labels, 4, CV_32S);
  std::vector<int> size(n, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u) ++size[l[u]];
  }
  std::vector<int> remap(n, 0);
  int next = 0;
  for (int i = 1; i < n; ++i) remap[i] = size[i] >= min_px ? ++next : 0;
  markers.create(labels.size(), CV_32SC1);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    int* m = markers.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u) m[u] = remap[l[u]];
  }
  if (fallback.empty()) return next;
  cv::Mat fb_labels;
  const int nf = cv::connectedComponents(fallback <= std::min(max_edge, 254), fb_labels, 4, CV_32S);
  std::vector<int> fb_size(nf, 0);
  std::vector<char> has_marker(nf, 0);
  for (int v = 0; v < fb_labels.rows; ++v) {
    const int* l = fb_labels.ptr<int>(v);
    const int* m = markers.ptr<int>(v);
    for (int u = 0; u < fb_labels.cols; ++u) {
      ++fb_size[l[u]];
      has_marker[l[u]] |= m[u] > 0;
    }
  }
  std::vector<int> fb_remap(nf, 0);
  for (int i = 1; i < nf; ++i) fb_remap[i] = (!has_marker[i] && fb_size[i] >= min_px) ? ++next : 0;
  for (int v = 0; v < fb_labels.rows; ++v) {
    const int* l = fb_labels.ptr<int>(v);
    int* m = markers.ptr<int>(v);
    for (int u = 0; u < fb_labels.cols; ++u) {
      if (fb_remap[l[u]]) m[u] = fb_remap[l[u]];
    }
  }
  return next;
}

// Floods `markers` (CV_32SC1, modified: every pixel ends with a label > 0 when at least one
// marker exists) over the relief `edges` by immersion: pixels are taken in order of their edge
// strength, and first-in first-out among equal strengths, so on a plateau of equal strength the
// basins advance at the same speed and meet in the middle.
//
// Why not cv::watershed: it orders pixels by the colour difference between a pixel and its
// labelled neighbour, not by height. Along the crest of an edge band that difference is ~0, so the
// first basin to reach a crest runs along it and takes the whole network of bands around every
// object (seen on mosd_tabletop: one region made of the rims of all objects plus strips of the
// table, leaving the table at 75% coverage). A bucket queue over the 256 levels is also O(N) and
// faster than cv::watershed plus the relief it needs.
void flood(const cv::Mat& edges, cv::Mat& markers) {
  const int rows = markers.rows, cols = markers.cols;
  CV_Assert(markers.isContinuous() && edges.isContinuous());
  int* L = markers.ptr<int>(0);
  const std::uint8_t* E = edges.ptr<std::uint8_t>(0);
  const int n = rows * cols;
  std::array<std::vector<int>, 256> bucket;
  // Seeds, in raster order: marker pixels with an unlabelled 4-neighbour (interior marker pixels
  // cannot spread).
  auto seed = [&](int v, int u) {
    const int i = v * cols + u;
    if (L[i] <= 0) return;
    const bool border = (u > 0 && L[i - 1] <= 0) || (u + 1 < cols && L[i + 1] <= 0) ||
                        (v > 0 && L[i - cols] <= 0) || (v + 1 < rows && L[i + cols] <= 0);
    if (border) bucket[E[i]].push_back(i);
  };
  for (int v = 0; v < rows; ++v) {
    int u = 0;
#if defined(__SSE2__)
    // Inside the image's border, four pixels per step: most are interior marker pixels or
    // unlabelled, so the set bits are few.
    if (v > 0 && v + 1 < rows && cols > 2) {
      seed(v, 0);
      auto load = [&](int i) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(L + i)); };
      const __m128i one = _mm_set1_epi32(1), zero = _mm_setzero_si128();
      for (u = 1; u + 5 <= cols; u += 4) {  // pixels u..u+3 and their right neighbours
        const int i = v * cols + u;
        const __m128i unlabelled_nb = _mm_or_si128(
            _mm_or_si128(_mm_cmpgt_epi32(one, load(i - 1)), _mm_cmpgt_epi32(one, load(i + 1))),
            _mm_or_si128(_mm_cmpgt_epi32(one, load(i - cols)),
                         _mm_cmpgt_epi32(one, load(i + cols))));
        const __m128i border = _mm_and_si128(_mm_cmpgt_epi32(load(i), zero), unlabelled_nb);
        for (int bits = _mm_movemask_ps(_mm_castsi128_ps(border)); bits != 0; bits &= bits - 1) {
          const int j = i + __builtin_ctz(static_cast<unsigned>(bits));
          bucket[E[j]].push_back(j);
        }
      }
    }
#endif
    for (; u < cols; ++u) seed(v, u);
  }
  for (int level = 0; level < 256; ++level) {
    std::vector<int>& q = bucket[level];
    for (std::size_t head = 0; head < q.size(); ++head) {  // q grows while it is read (FIFO)
      const int i = q[head];
      const int label = L[i];
      const int u = i % cols;
      const int nb[4] = {u > 0 ? i - 1 : -1, u + 1 < cols ? i + 1 : -1, i - cols, i + cols};
      for (int j : nb) {
        if (j < 0 || j >= n || L[j] > 0) continue;
        L[j] = label;
        bucket[std::max<int>(level, E[j])].push_back(j);
      }
    }
    std::vector<int>().swap(q);
  }
}

// Working-resolution labels (CV_32SC1, ids up to max_label) renumbered 1..K in raster order of
// first appearance, so that the full-resolution passes below run on uint16. K is at most the
// number of pixels / min marker size, far below 65535 for any sane parameters; ids past 65535
// become 0 (unassigned) rather than wrapping.
cv::Mat denseLabels(const cv::Mat& labels, int max_label, int& count) {
  std::vector<std::uint16_t> remap(static_cast<std::size_t>(std::max(max_label, 0)) + 1, 0);
  std::vector<char> assigned(remap.size(), 0);
  int next = 0;
  cv::Mat out(labels.size(), CV_16UC1);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const int x = std::max(l[u], 0);
      if (x > 0 && !assigned[x]) {
        assigned[x] = 1;
        remap[x] = next < 65535 ? static_cast<std::uint16_t>(++next) : 0;
      }
      o[u] = remap[x];
    }
  }
  count = std::min(next, 65535);
  return out;
}

#if defined(__SSE2__)
// upsample's expansion of working columns uc..uc+3 (uc = u / 2) to full-resolution columns
// u..u+7: each block's label, depth and depth tolerance twice, the tolerance with the same float
// operations as the scalar loop.
void expandBlocks4(const std::uint16_t* l, const std::uint16_t* dc, int u, float k,
                   std::uint16_t* lab2, std::uint16_t* dep2, std::uint16_t* tol2) {
  const int uc = u >> 1;
  auto load4 = [](const std::uint16_t* p) {
    return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p));
  };
  auto twice = [](__m128i x4) { return _mm_unpacklo_epi16(x4, x4); };  // a a b b c c d d
  auto store = [](std::uint16_t* p, __m128i x) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p), x);
  };
  const __m128i z4 = load4(dc + uc);
  const __m128 z = _mm_cvtepi32_ps(_mm_unpacklo_epi16(z4, _mm_setzero_si128()));
  const __m128 t =
      _mm_min_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(k), z), z), _mm_set1_ps(2.0f)),
                 _mm_set1_ps(65535.0f));
  // uint16 from int32 <= 0xFFFF: shifted into the signed range for the saturating pack, and back.
  const __m128i t4 =
      _mm_add_epi16(_mm_packs_epi32(_mm_sub_epi32(_mm_cvttps_epi32(t), _mm_set1_epi32(0x8000)),
                                    _mm_setzero_si128()),
                    _mm_set1_epi16(static_cast<short>(0x8000)));
  store(lab2 + u, twice(load4(l + uc)));
  store(dep2 + u, twice(z4));
  store(tol2 + u, twice(t4));
}

// upsample's per-pixel pass over pixels u..u+7: the block label where there is depth (else 0),
// and bad = 1 where the depth is off the block's by more than its tolerance. Returns whether any
// is bad. |z - c| > t with saturating subtraction (SSE2 has no unsigned 16-bit compare).
unsigned labelPixels8(const std::uint16_t* d, const std::uint16_t* lab2, const std::uint16_t* dep2,
                      const std::uint16_t* tol2, int u, std::uint16_t* o, std::uint8_t* bad) {
  auto load = [](const std::uint16_t* p) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
  };
  const __m128i zero = _mm_setzero_si128();
  const __m128i z = load(d + u), c = load(dep2 + u);
  const __m128i no_depth = _mm_cmpeq_epi16(z, zero);
  const __m128i diff = _mm_or_si128(_mm_subs_epu16(z, c), _mm_subs_epu16(c, z));
  const __m128i within = _mm_cmpeq_epi16(_mm_subs_epu16(diff, load(tol2 + u)), zero);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(o + u), _mm_andnot_si128(no_depth, load(lab2 + u)));
  const __m128i is_bad = _mm_andnot_si128(_mm_or_si128(no_depth, within), _mm_set1_epi16(-1));
  _mm_storel_epi64(reinterpret_cast<__m128i*>(bad + u),
                   _mm_packs_epi16(_mm_and_si128(is_bad, _mm_set1_epi16(1)), zero));
  return static_cast<unsigned>(_mm_movemask_epi8(is_bad));
}
#endif

// Upsamples working-resolution labels (dense uint16, see denseLabels) to the full image. A
// full-resolution pixel whose depth does not match its block's depth (a block on a step took the
// foreground) takes the label of the neighbouring block with the closest depth. Pixels without
// depth get 0. CV_16UC1.
cv::Mat upsample(const cv::Mat& labels, const Working& w, const cv::Mat& depth,
                 const KinectNoiseModel& noise) {
  cv::Mat out(depth.size(), CV_16UC1);
  if (w.ds == 1) {  // makeWorking clamps ds to 1 or 2
    for (int v = 0; v < depth.rows; ++v) {
      const auto* d = depth.ptr<std::uint16_t>(v);
      const auto* l = labels.ptr<std::uint16_t>(v);
      auto* o = out.ptr<std::uint16_t>(v);
      for (int u = 0; u < depth.cols; ++u) o[u] = d[u] == 0 ? 0 : l[u];
    }
    return out;
  }
  // Per working row, the block label, depth and depth tolerance are expanded to full width once,
  // so the per-pixel pass is branch-free uint16 arithmetic that vectorises; the few pixels that
  // do not match their block (next to steps) are fixed afterwards.
  const float k =
      static_cast<float>(3.0 * noise.disparity_step_px / noise.focal_baseline_px_m * 1e-3);
  const int cols = depth.cols;
  std::vector<std::uint16_t> lab2(cols), dep2(cols), tol2(cols);
  std::vector<std::uint8_t> bad(cols);
  for (int v = 0; v < depth.rows; ++v) {
    const auto* d = depth.ptr<std::uint16_t>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    const int vc = std::min(v / 2, labels.rows - 1);
    const auto* l = labels.ptr<std::uint16_t>(vc);
    const auto* dc = w.depth.ptr<std::uint16_t>(vc);
    if (v % 2 == 0) {
      int u = 0;
#if defined(__SSE2__)
      for (; u + 8 <= cols && (u >> 1) + 4 <= labels.cols; u += 8)
        expandBlocks4(l, dc, u, k, lab2.data(), dep2.data(), tol2.data());
#endif
      for (; u < cols; u += 2) {
        const int uc = std::min(u >> 1, labels.cols - 1);
        const float z = dc[uc];
        const auto t = static_cast<std::uint16_t>(std::min(k * z * z + 2.0f, 65535.0f));
        const int n = std::min(2, cols - u);
        for (int i = 0; i < n; ++i) {
          lab2[u + i] = l[uc];
          dep2[u + i] = dc[uc];
          tol2[u + i] = t;
        }
      }
    }
    unsigned any_bad = 0;
    int u = 0;
#if defined(__SSE2__)
    for (; u + 8 <= cols; u += 8)
      any_bad |= labelPixels8(d, lab2.data(), dep2.data(), tol2.data(), u, o, bad.data());
#endif
    for (; u < cols; ++u) {
      const std::uint16_t z = d[u], c = dep2[u];
      const std::uint16_t diff = static_cast<std::uint16_t>(z > c ? z - c : c - z);
      const std::uint16_t valid = z != 0 ? 0xFFFF : 0;
      o[u] = static_cast<std::uint16_t>(lab2[u] & valid);
      bad[u] = static_cast<std::uint8_t>((valid & (diff > tol2[u] ? 1 : 0)));
      any_bad |= bad[u];
    }
    if (!any_bad) continue;
    for (int u = 0; u < cols; ++u) {
      if (std::uint64_t eight; u + 8 <= cols && (std::memcpy(&eight, &bad[u], 8), eight == 0)) {
        u += 7;  // none of the eight
        continue;
      }
      if (!bad[u]) continue;
      const int uc = std::min(u >> 1, labels.cols - 1);
      int best = 1 << 30;
      for (int dv = -1; dv <= 1; ++dv) {
        const int vv = vc + dv;
        if (vv < 0 || vv >= labels.rows) continue;
        const auto* lr = labels.ptr<std::uint16_t>(vv);
        const auto* dr = w.depth.ptr<std::uint16_t>(vv);
        for (int du = -1; du <= 1; ++du) {
          const int uu = uc + du;
          if (uu < 0 || uu >= labels.cols || dr[uu] == 0 || lr[uu] == 0) continue;
          const int diff = std::abs(static_cast<int>(d[u]) - static_cast<int>(dr[uu]));
          if (diff < best) {
            best = diff;
            o[u] = lr[uu];
          }
        }
      }
    }
  }
  return out;
}

// The end of the run of equal labels that starts at u in a row of `cols` labels.
int runEnd(const std::uint16_t* l, int u, int cols) {
  const std::uint16_t x = l[u];
  int end = u + 1;
  // Four labels per compare while the run lasts (runs are long: regions are large).
  const std::uint64_t four = x * 0x0001000100010001ull;
  for (std::uint64_t chunk; end + 4 <= cols; end += 4) {
    std::memcpy(&chunk, l + end, sizeof chunk);
    if (chunk != four) break;
  }
  while (end < cols && l[end] == x) ++end;
  return end;
}

// Drops regions below min_px and renumbers the rest 1..N in raster order of first appearance,
// in place (CV_16UC1 with labels <= max_label).
void compact(cv::Mat& labels, int max_label, int min_px) {
  // By runs of equal labels: consecutive pixels mostly share a label, and a per-pixel
  // ++size[label] is a serial memory dependency that costs more than the upsampling.
  std::vector<int> size(static_cast<std::size_t>(max_label) + 1, 0);
  std::vector<std::uint16_t> order;  // labels in raster order of first appearance
  for (int v = 0; v < labels.rows; ++v) {
    const auto* l = labels.ptr<std::uint16_t>(v);
    int u = 0;
    while (u < labels.cols) {
      const std::uint16_t x = l[u];
      const int end = runEnd(l, u, labels.cols);
      if (x != 0 && size[x] == 0) order.push_back(x);
      size[x] += end - u;
      u = end;
    }
  }
  std::vector<std::uint16_t> remap(static_cast<std::size_t>(max_label) + 1, 0);
  int next = 0;
  bool identity = true;
  for (std::uint16_t x : order) {
    if (size[x] >= min_px) remap[x] = static_cast<std::uint16_t>(++next);
    identity = identity && remap[x] == x;
  }
  if (identity && static_cast<int>(order.size()) == max_label) return;
  for (int v = 0; v < labels.rows; ++v) {
    auto* l = labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols;) {
      const int end = runEnd(l, u, labels.cols);
      std::fill(l + u, l + end, remap[l[u]]);
      u = end;
    }
  }
}

// Greedy merge of coplanar regions (see RegionParams::merge_coplanar) of labels (CV_32SC1, ids
// up to max_label). Moments of (u, v, w = 1/z) are additive, so the plane fit of any union is
// O(1) from its parts' sums.
void mergeCoplanar(cv::Mat& labels, int max_label, const cv::Mat& edges, const Working& w,
                   const RegionParams& rp) {
  if (!rp.merge_coplanar) return;
  const int n = max_label + 1;
  if (n <= 2) return;
  using Moments = std::array<double, 10>;  // n u v w uu uv vv uw vw ww
  std::vector<Moments> m(n, Moments{});
  const double uc = labels.cols * 0.5, vc = labels.rows * 0.5;
  // Row-local sums over runs of one label, flushed into the region's moments when the label
  // changes: no per-pixel read-modify-write of a region's moments in memory.
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const auto* d = w.depth.ptr<std::uint16_t>(v);
    const auto* e = edges.ptr<std::uint8_t>(v);
    const double fv = v - vc;
    int cur = 0;
    double c = 0, su = 0, suu = 0, sw = 0, suw = 0, sww = 0;
    auto flush = [&] {
      if (cur <= 0 || c == 0) return;
      Moments& a = m[cur];
      a[0] += c;
      a[1] += su;
      a[2] += fv * c;
      a[3] += sw;
      a[4] += suu;
      a[5] += fv * su;
      a[6] += fv * fv * c;
      a[7] += suw;
      a[8] += fv * sw;
      a[9] += sww;
      c = su = suu = sw = suw = sww = 0;
    };
    for (int u = 0; u < labels.cols; ++u) {
      // Only the regions' cores (low edge strength): flooded edge bands hold mixed pixels.
      if (l[u] <= 0 || d[u] == 0 || e[u] > rp.marker_max_edge) continue;
      if (l[u] != cur) {
        flush();
        cur = l[u];
      }
      const double fu = u - uc, iw = 1000.0f / static_cast<float>(d[u]);
      c += 1;
      su += fu;
      suu += fu * fu;
      sw += iw;
      suw += fu * iw;
      sww += iw * iw;
    }
    flush();
  }
  auto rms = [](const Moments& a) {
    const cv::Matx33d A(a[4], a[5], a[1], a[5], a[6], a[2], a[1], a[2], a[0]);
    const cv::Vec3d b(a[7], a[8], a[3]);
    cv::Vec3d x;
    if (!cv::solve(A, b, x, cv::DECOMP_CHOLESKY)) return 1e9;
    return std::sqrt(std::max(0.0, a[9] - x.dot(b)) / a[0]);
  };
  const double t = rp.coplanar_rms_steps * inverseDepthStep(rp.noise);
  const double min_n = static_cast<double>(rp.coplanar_min_px) / (w.ds * w.ds);
  std::vector<int> cand;
  for (int i = 1; i < n; ++i) {
    if (m[i][0] > 0 && m[i][0] >= min_n && rms(m[i]) <= t) cand.push_back(i);
  }
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (;;) {
    double best = t;
    int bi = -1, bj = -1;
    for (std::size_t a = 0; a < cand.size(); ++a) {
      for (std::size_t b = a + 1; b < cand.size(); ++b) {
        Moments u = m[cand[a]];
        for (int k = 0; k < 10; ++k) u[k] += m[cand[b]][k];
        const double r = rms(u);
        if (r <= best) {
          best = r;
          bi = static_cast<int>(a);
          bj = static_cast<int>(b);
        }
      }
    }
    if (bi < 0) break;
    const int i = cand[bi], j = cand[bj];
    for (int k = 0; k < 10; ++k) m[i][k] += m[j][k];
    parent[j] = i;
    cand.erase(cand.begin() + bj);
  }
  for (int i = 1; i < n; ++i) {
    int r = i;
    while (parent[r] != r) r = parent[r];
    parent[i] = r;
  }
  for (int v = 0; v < labels.rows; ++v) {
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] > 0) l[u] = parent[l[u]];
  }
}

// The full-resolution regions from flooded working-resolution markers (ids up to max_label).
cv::Mat finish(cv::Mat& markers, int max_label, const cv::Mat& edges, const Working& w,
               const cv::Mat& depth, const RegionParams& rp) {
  mergeCoplanar(markers, max_label, edges, w, rp);
  int count = 0;
  cv::Mat full = upsample(denseLabels(markers, max_label, count), w, depth, rp.noise);
  compact(full, count, rp.min_region_px);
  return full;
}

// ---------------------------------------------------------------------------------------------
// Tiled RANSAC

struct TilePlane {
  bool ok = false;
  double a = 0, b = 0, c = 0;  // w = a*u + b*v + c (working pixels, inverse depth 1/m)
  int inliers = 0;
};

struct Lcg {
  std::uint32_t s;
  std::uint32_t next() {
    s = s * 1664525u + 1013904223u;
    return s >> 8;
  }
};

// Least-squares w = a u + b v + c over points (centred at (u0, v0) for conditioning).
bool fitPlaneLs(const std::vector<cv::Point3f>& pts, const std::vector<int>& idx, TilePlane& out) {
  if (idx.size() < 3) return false;
  double su = 0, sv = 0, sw = 0, suu = 0, suv = 0, svv = 0, suw = 0, svw = 0;
  const double n = static_cast<double>(idx.size());
  double mu = 0, mv = 0;
  for (int i : idx) {
    mu += pts[i].x;
    mv += pts[i].y;
  }
  mu /= n;
  mv /= n;
  for (int i : idx) {
    const double u = pts[i].x - mu, v = pts[i].y - mv, w = pts[i].z;
    su += u;
    sv += v;
    sw += w;
    suu += u * u;
    suv += u * v;
    svv += v * v;
    suw += u * w;
    svw += v * w;
  }
  const double det = suu * svv - suv * suv;
  if (std::fabs(det) < 1e-9) return false;
  const double a = (suw * svv - svw * suv) / det;
  const double b = (svw * suu - suw * suv) / det;
  const double c = (sw - a * su - b * sv) / n;
  out.a = a;
  out.b = b;
  out.c = c - a * mu - b * mv;
  return true;
}

int findRoot(std::vector<int>& parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

cv::Mat tiledRansac(const cv::Mat& depth, const CameraIntrinsics& intr,
                    const TiledRansacParams& p) {
  const RegionParams& rp = p.region;
  const Working w = makeWorking(depth, intr, rp);
  const cv::Mat inv = inverseDepth(w.depth);
  const int rows = inv.rows, cols = inv.cols;
  const int ts = std::max(4, p.tile_size);
  const int tx_n = (cols + ts - 1) / ts, ty_n = (rows + ts - 1) / ts;
  const float thr = static_cast<float>(p.inlier_noise_steps * inverseDepthStep(rp.noise));
  std::vector<TilePlane> planes(static_cast<std::size_t>(tx_n) * ty_n);
  std::vector<cv::Point3f> pts;
  std::vector<int> inl, best_inl;
  pts.reserve(ts * ts);

  auto tileRect = [&](int tx, int ty) {
    return cv::Rect(tx * ts, ty * ts, std::min(ts, cols - tx * ts), std::min(ts, rows - ty * ts));
  };
  // 1. RANSAC per tile.
  for (int ty = 0; ty < ty_n; ++ty) {
    for (int tx = 0; tx < tx_n; ++tx) {
      const cv::Rect rc = tileRect(tx, ty);
      pts.clear();
      for (int v = rc.y; v < rc.y + rc.height; ++v) {
        const float* row = inv.ptr<float>(v);
        for (int u = rc.x; u < rc.x + rc.width; ++u) {
          if (row[u] > 0) pts.emplace_back(static_cast<float>(u), static_cast<float>(v), row[u]);
        }
      }
      const int n = static_cast<int>(pts.size());
      if (n < std::max(12, rc.area() / 3)) continue;
      Lcg rng{p.seed * 2654435761u + static_cast<std::uint32_t>(ty * tx_n + tx) * 40503u + 1u};
      int best = 0;
      TilePlane best_plane;
      for (int it = 0; it < p.iterations; ++it) {
        const auto& a = pts[rng.next() % n];
        const auto& b = pts[rng.next() % n];
        const auto& c = pts[rng.next() % n];
        // Solve w = A u + B v + C through three points.
        const double u1 = b.x - a.x, v1 = b.y - a.y, w1 = b.z - a.z;
        const double u2 = c.x - a.x, v2 = c.y - a.y, w2 = c.z - a.z;
        const double det = u1 * v2 - u2 * v1;
        if (std::fabs(det) < 4.0) continue;  // nearly collinear samples
        TilePlane h;
        h.a = (w1 * v2 - w2 * v1) / det;
        h.b = (u1 * w2 - u2 * w1) / det;
        h.c = a.z - h.a * a.x - h.b * a.y;
        int cnt = 0;
        const float ha = static_cast<float>(h.a), hb = static_cast<float>(h.b),
                    hc = static_cast<float>(h.c);
        for (int i = 0; i < n; i += 2)
          cnt += std::fabs(pts[i].z - (ha * pts[i].x + hb * pts[i].y + hc)) <= thr;
        if (cnt > best) {
          best = cnt;
          best_plane = h;
        }
      }
      if (best == 0) continue;
      // Refine on the inliers, then recount on all pixels.
      for (int round = 0; round < 2; ++round) {
        inl.clear();
        const float ha = static_cast<float>(best_plane.a), hb = static_cast<float>(best_plane.b),
                    hc = static_cast<float>(best_plane.c);
        for (int i = 0; i < n; ++i) {
          if (std::fabs(pts[i].z - (ha * pts[i].x + hb * pts[i].y + hc)) <= thr) inl.push_back(i);
        }
        if (round == 0 && !fitPlaneLs(pts, inl, best_plane)) break;
      }
      TilePlane& tp = planes[ty * tx_n + tx];
      tp = best_plane;
      tp.inliers = static_cast<int>(inl.size());
      tp.ok = tp.inliers >= p.min_inlier_fraction * n;
    }
  }
  // 2. Merge neighbouring tiles whose planes explain each other's inliers.
  const int nt = tx_n * ty_n;
  std::vector<int> parent(nt);
  std::iota(parent.begin(), parent.end(), 0);
  auto fits = [&](const TilePlane& a, float u, float v, float wv, float t) {
    return std::fabs(wv - static_cast<float>(a.a * u + a.b * v + a.c)) <= t;
  };
  auto crossFit = [&](int ia, int ib) {
    // Fraction of b's inliers explained by a (sampled every other pixel).
    const TilePlane& A = planes[ia];
    const TilePlane& B = planes[ib];
    const cv::Rect rc = tileRect(ib % tx_n, ib / tx_n);
    int both = 0, total = 0;
    for (int v = rc.y; v < rc.y + rc.height; v += 2) {
      const float* row = inv.ptr<float>(v);
      for (int u = rc.x; u < rc.x + rc.width; u += 2) {
        if (row[u] <= 0) continue;
        const float fu = static_cast<float>(u), fv = static_cast<float>(v);
        if (!fits(B, fu, fv, row[u], thr)) continue;
        ++total;
        both += fits(A, fu, fv, row[u], 1.5f * thr);
      }
    }
    return total > 0 ? static_cast<double>(both) / total : 0.0;
  };
  for (int ty = 0; ty < ty_n; ++ty) {
    for (int tx = 0; tx < tx_n; ++tx) {
      const int i = ty * tx_n + tx;
      if (!planes[i].ok) continue;
      for (int j : {tx + 1 < tx_n ? i + 1 : -1, ty + 1 < ty_n ? i + tx_n : -1}) {
        if (j < 0 || !planes[j].ok) continue;
        if (crossFit(i, j) >= p.merge_fraction && crossFit(j, i) >= p.merge_fraction) {
          parent[findRoot(parent, i)] = findRoot(parent, j);
        }
      }
    }
  }
  // 3. Flood: seeds are each accepted tile's inliers; a pixel joins a neighbour's region when it
  // fits the plane of its own tile (if that tile belongs to the region) or else the plane the
  // neighbour was grown with. This crosses tile borders, so tiles leave no seams, and follows
  // gently curved surfaces whose tile planes were chained by the merge.
  cv::Mat labels(rows, cols, CV_32SC1, cv::Scalar(0));
  std::vector<int> plane_of(static_cast<std::size_t>(rows) * cols, -1);
  std::vector<int> queue;
  queue.reserve(static_cast<std::size_t>(rows) * cols);
  for (int v = 0; v < rows; ++v) {
    const float* row = inv.ptr<float>(v);
    int* l = labels.ptr<int>(v);
    const int ty = v / ts;
    for (int u = 0; u < cols; ++u) {
      const int t = ty * tx_n + u / ts;
      if (row[u] <= 0 || !planes[t].ok) continue;
      if (!fits(planes[t], static_cast<float>(u), static_cast<float>(v), row[u], thr)) continue;
      l[u] = findRoot(parent, t) + 1;
      plane_of[v * cols + u] = t;
      queue.push_back(v * cols + u);
    }
  }
  int* L = labels.ptr<int>(0);
  const float* W = inv.ptr<float>(0);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int idx = queue[head];
    const int u = idx % cols, v = idx / cols;
    const int label = L[idx];
    const int pl = plane_of[idx];
    const int nbr[4] = {u > 0 ? idx - 1 : -1, u + 1 < cols ? idx + 1 : -1, v > 0 ? idx - cols : -1,
                        v + 1 < rows ? idx + cols : -1};
    for (int q : nbr) {
      if (q < 0 || L[q] != 0 || W[q] <= 0) continue;
      const int qu = q % cols, qv = q / cols;
      const int tq = (qv / ts) * tx_n + qu / ts;
      int use = pl;
      if (planes[tq].ok && findRoot(parent, tq) + 1 == label) use = tq;
      if (!fits(planes[use], static_cast<float>(qu), static_cast<float>(qv), W[q], thr)) continue;
      L[q] = label;
      plane_of[q] = use;
      queue.push_back(q);
    }
  }
  // 4. Non-planar leftovers: components of unlabelled depth-continuous pixels become regions;
  // the rest is flooded over the depth-step relief.
  const cv::Mat edges = depthStepEdges(w, p.leftovers, rp.noise);
  cv::Mat left_mask(rows, cols, CV_8UC1);
  for (int v = 0; v < rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const auto* e = edges.ptr<std::uint8_t>(v);
    auto* m = left_mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < cols; ++u) m[u] = (l[u] == 0 && e[u] <= rp.marker_max_edge) ? 255 : 0;
  }
  cv::Mat comp;
  const int nc = cv::connectedComponents(left_mask, comp, 4, CV_32S);
  std::vector<int> csize(nc, 0);
  for (int v = 0; v < rows; ++v) {
    const int* c = comp.ptr<int>(v);
    for (int u = 0; u < cols; ++u) ++csize[c[u]];
  }
  const int min_marker = std::max(1, rp.min_marker_px / (w.ds * w.ds));
  for (int v = 0; v < rows; ++v) {
    const int* c = comp.ptr<int>(v);
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < cols; ++u) {
      if (c[u] > 0 && csize[c[u]] >= min_marker) l[u] = nt + c[u];
    }
  }
  flood(edges, labels);
  return finish(labels, nt + nc, edges, w, depth, rp);
}

}  // namespace

cv::Mat segmentationEdgeStrength(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                 SegmentationMethod method, const SegmentationParams& params) {
  if (method == SegmentationMethod::kTiledRansac) return {};
  const RegionParams& rp = regionParams(method, params);
  const Working w = makeWorking(depth_mm, intrinsics, rp);
  return edgeStrength(w, method, params);
}

cv::Mat segmentDepth(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                     SegmentationMethod method, const SegmentationParams& params) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  if (method == SegmentationMethod::kTiledRansac) {
    return tiledRansac(depth_mm, intrinsics, params.tiled_ransac);
  }
  const RegionParams& rp = regionParams(method, params);
  const Working w = makeWorking(depth_mm, intrinsics, rp);
  cv::Mat edges, fallback;
  if (method == SegmentationMethod::kPlanePrediction) {
    const auto& pp = params.plane_prediction;
    edges = planePredictionEdges(w, pp, rp.noise, pp.curved_fallback_markers ? &fallback : nullptr);
  } else {
    edges = edgeStrength(w, method, params);
  }
  cv::Mat markers;
  const int min_marker = std::max(1, rp.min_marker_px / (w.ds * w.ds));
  const int marker_count =
      markersFromEdges(edges, rp.marker_max_edge, min_marker, markers, fallback);
  if (marker_count == 0) {
    return cv::Mat(depth_mm.size(), CV_16UC1, cv::Scalar(0));
  }
  flood(edges, markers);
  return finish(markers, marker_count, edges, w, depth_mm, rp);
}

}  // namespace shapesense
