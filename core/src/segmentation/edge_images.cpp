#include "segmentation/edge_images.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "segmentation/segmentation_kernels.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense::segmentation {

namespace {

// Per-pixel threshold (uint16 mm) of each ring at Chebyshev distance 1..r, so that the counts
// are uint16 compares.
std::vector<cv::Mat> ringThresholds(const WorkingImage& w, const DepthStepEdgeParams& p,
                                    const KinectNoiseModel& noise, int r) {
  const cv::Mat& d = w.depth;
  std::vector<cv::Mat> thr(r);
  for (auto& t : thr) t.create(d.rows, d.cols, CV_16UC1);
  const float step_k = static_cast<float>(p.noise_steps * noise.disparity_step_px /
                                          noise.focal_baseline_px_m * 1e-3);
  const float slope = static_cast<float>(p.slope_factor * w.ds);
  const float min_t = static_cast<float>(p.min_threshold_mm);
  for (int v = 0; v < d.rows; ++v) {
    const auto* dp = d.ptr<std::uint16_t>(v);
    for (int k = 0; k < r; ++k) {
      auto* t = thr[k].ptr<std::uint16_t>(v);
      const float ring = static_cast<float>(k + 1);
      for (int u = 0; u < d.cols; ++u) {
        const float z = static_cast<float>(dp[u]);
        const float th = std::max(min_t, step_k * z * z + slope * ring * z);
        t[u] = static_cast<std::uint16_t>(std::min(th, 65535.0f));
      }
    }
  }
  return thr;
}

}  // namespace

cv::Mat depthStepEdges(const WorkingImage& w, const DepthStepEdgeParams& p,
                       const KinectNoiseModel& noise) {
  const cv::Mat& d = w.depth;
  const int rows = d.rows, cols = d.cols;
  const int r = std::clamp(p.window_radius, 1, 7);
  const std::vector<cv::Mat> thr = ringThresholds(w, p, noise, r);
  cv::Mat edges(rows, cols, CV_8UC1);
  std::vector<const std::uint16_t*> window_rows(2 * r + 1);  // nullptr: outside the image
  std::vector<const std::uint16_t*> thr_rows(r);             // row v of each ring's thresholds
  const StepWindow window{r, window_rows.data(), thr_rows.data(), 0};
  for (int v = 0; v < rows; ++v) {
    for (int k = 0; k < r; ++k) thr_rows[k] = thr[k].ptr<std::uint16_t>(v);
    int offsets = 0;
    for (int dv = -r; dv <= r; ++dv) {
      const int vq = v + dv;
      const bool inside = vq >= 0 && vq < rows;
      window_rows[dv + r] = inside ? d.ptr<std::uint16_t>(vq) : nullptr;
      offsets += inside ? (dv == 0 ? 2 * r : 2 * r + 1) : 0;
    }
    StepWindow row_window = window;
    row_window.offsets = offsets;
    countDepthSteps(d.ptr<std::uint16_t>(v), row_window, cols, edges.ptr<std::uint8_t>(v));
  }
  return edges;
}

// Normals are NaN next to depth steps (their windows must not straddle a step). Alone
// (`invalid_is_edge`), that band is the only trace of a step, so a neighbour with depth but no
// normal counts as differing and a centre without normal gets the full count. In the fused
// method the depth-step term detects the steps, so there the band counts nothing: otherwise the
// normal term saturates exactly where the depth term fires and the depth cue adds nothing.
cv::Mat normalEdges(const WorkingImage& w, const NormalAngleEdgeParams& p, bool invalid_is_edge) {
  const int rows = w.depth.rows, cols = w.depth.cols;
  NormalEstimator est(p.normals);
  cv::Mat normals;
  est.compute(w.depth, w.intr, normals);
  const int r = std::clamp(p.window_radius, 1, 7);
  const float cos_t = static_cast<float>(std::cos(degToRad(p.max_angle_deg)));
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

cv::Mat fusedEdges(const WorkingImage& w, const FusedParams& f) {
  const cv::Mat ed = depthStepEdges(w, f.depth, f.region.noise);
  const cv::Mat en = normalEdges(w, f.normal, f.invalid_normal_is_edge);
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

namespace {

// Box-filtered inverse depth (0 where fewer than half the window is valid).
cv::Mat smoothedInverseDepth(const cv::Mat& depth, const cv::Mat& inv, int s) {
  cv::Mat mask;
  cv::compare(depth, 0, mask, cv::CMP_NE);
  mask.convertTo(mask, CV_32F, 1.0 / 255.0);
  cv::Mat inv_sum, cnt;
  cv::boxFilter(inv, inv_sum, CV_32F, cv::Size(2 * s + 1, 2 * s + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  cv::boxFilter(mask, cnt, CV_32F, cv::Size(2 * s + 1, 2 * s + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  const float min_cnt = 0.5f * static_cast<float>((2 * s + 1) * (2 * s + 1));
  cv::Mat sm;
  cv::divide(inv_sum, cv::max(cnt, min_cnt), sm);
  sm.setTo(0.0f, cnt < min_cnt);
  return sm;
}

// The smoothed inverse depth's gradient over +-g pixels (inverseDepthGradientRow).
void inverseDepthGradient(const cv::Mat& sm, int g, cv::Mat& gx, cv::Mat& gy) {
  const int rows = sm.rows, cols = sm.cols;
  gx.create(rows, cols, CV_32F);
  gy.create(rows, cols, CV_32F);
  for (int v = 0; v < rows; ++v)
    inverseDepthGradientRow(v - g >= 0 ? sm.ptr<float>(v - g) : nullptr, sm.ptr<float>(v),
                            v + g < rows ? sm.ptr<float>(v + g) : nullptr, g, cols,
                            gx.ptr<float>(v), gy.ptr<float>(v));
}

struct PredictionOffset {
  int du, dv;
  bool long_range;
};

// The dense window, then the long-range ring (the outer ring of a grid with spacing
// long_range / 2, i.e. 16 neighbours at distance long_range).
std::vector<PredictionOffset> predictionOffsets(const PlanePredictionParams& p) {
  std::vector<PredictionOffset> offsets;
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
  return offsets;
}

}  // namespace

// Planes are affine in inverse depth w = 1/z, so each neighbour's w is predicted from the
// centre's smoothed w and gradient; E = number of anomalous neighbours.
cv::Mat planePredictionEdges(const WorkingImage& w, const PlanePredictionParams& p,
                             const KinectNoiseModel& noise, cv::Mat* short_edges) {
  const cv::Mat& d = w.depth;
  const int rows = d.rows, cols = d.cols;
  const cv::Mat inv = inverseDepth(d);
  const cv::Mat sm = smoothedInverseDepth(d, inv, std::max(0, p.smoothing_radius));
  cv::Mat gx, gy;
  inverseDepthGradient(sm, std::max(1, p.gradient_step), gx, gy);
  const float thr = static_cast<float>(p.noise_steps * inverseDepthStep(noise));
  const float thr_long = static_cast<float>(p.long_noise_steps * inverseDepthStep(noise));
  const std::vector<PredictionOffset> offsets = predictionOffsets(p);
  cv::Mat edges(rows, cols, CV_8UC1);
  if (short_edges) short_edges->create(rows, cols, CV_8UC1);
  // Rows padded with `reach` columns of no reading on each side: a neighbour off the image
  // then counts as a neighbour without depth, which is never anomalous. No reading is NaN here.
  int reach = 0;
  for (const PredictionOffset& o : offsets) reach = std::max(reach, std::abs(o.du));
  cv::Mat padded;
  cv::copyMakeBorder(inv, padded, 0, 0, reach, reach, cv::BORDER_CONSTANT,
                     cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  padded.setTo(std::numeric_limits<float>::quiet_NaN(), padded == 0.0f);
  std::vector<PredictionNeighbour> neighbours;
  for (int v = 0; v < rows; ++v) {
    neighbours.clear();
    for (const PredictionOffset& o : offsets) {
      const int vq = v + o.dv;
      if (vq >= 0 && vq < rows)
        neighbours.push_back({padded.ptr<float>(vq) + reach, o.du, o.dv,
                              o.long_range ? thr_long : thr, o.long_range});
    }
    predictionEdgesRow(inv.ptr<float>(v), sm.ptr<float>(v), gx.ptr<float>(v), gy.ptr<float>(v),
                       neighbours.data(), static_cast<int>(neighbours.size()), cols,
                       edges.ptr<std::uint8_t>(v),
                       short_edges ? short_edges->ptr<std::uint8_t>(v) : nullptr);
  }
  return edges;
}

cv::Mat edgeStrength(const WorkingImage& w, SegmentationMethod method,
                     const SegmentationParams& params) {
  switch (method) {
    case SegmentationMethod::kDepthStep:
      return depthStepEdges(w, params.depth_step, params.depth_step.region.noise);
    case SegmentationMethod::kNormalEdges:
      return normalEdges(w, params.normal_edges);
    case SegmentationMethod::kFused:
      return fusedEdges(w, params.fused);
    case SegmentationMethod::kPlanePrediction:
    case SegmentationMethod::kPlanesAndObjects:  // its object regions are plane_prediction's
      return planePredictionEdges(w, params.plane_prediction, params.plane_prediction.region.noise);
    case SegmentationMethod::kTiledRansac:
      break;
  }
  return {};
}

}  // namespace shapesense::segmentation
