#include "sensor_model.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "ray_span.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

int projectorShadowColumns(const SceneParams& params) {
  const KinectParams& kp = params.kinect;
  if (!kp.projector_shadows) return 0;
  return static_cast<int>(
             std::ceil(params.intrinsics.fx * kp.projector_baseline_m / kp.min_range_m)) +
         2;
}

// Camera and projector are rectified along x, so each image row is one epipolar plane for both
// and a point at column u appears at projector column u - f*b/z. Scanning a row from the right,
// a point is hidden from the projector exactly when some point to its right already occupies a
// smaller projector column (the projector's view of the row folds over it).
std::vector<std::uint8_t> projectorShadows(const HitBuffer& hits, int image_width, double fx,
                                           double baseline) {
  std::vector<std::uint8_t> shadow(static_cast<std::size_t>(image_width) * hits.height, 0);
  const double fb = fx * baseline;
  for (int v = 0; v < hits.height; ++v) {
    double min_projector_u = kInf;
    for (int u = hits.width - 1; u >= 0; --u) {
      const double z = hits.depth[hits.index(u, v)];
      if (!std::isfinite(z)) continue;
      const double projector_u = u - fb / z;
      if (projector_u > min_projector_u + 1e-6) {
        if (u < image_width) shadow[static_cast<std::size_t>(v) * image_width + u] = 1;
      } else {
        min_projector_u = std::min(min_projector_u, projector_u);
      }
    }
  }
  return shadow;
}

SensorModel::SensorModel(const SceneParams& params, const SceneModel& model, std::uint64_t index)
    : params_(params),
      model_(model),
      noise_(frameNoiseSeed(params.seed, index)),
      artefacts_(artefactSeed(frameNoiseSeed(params.seed, index))),
      cos_max_incidence_(std::cos(degToRad(params.kinect.max_incidence_deg))) {}

void SensorModel::apply(const HitBuffer& hits, const Eigen::Isometry3d& world_from_camera,
                        Frame& frame, TruthFrame& truth) const {
  const CameraIntrinsics& k = params_.intrinsics;
  const KinectParams& kp = params_.kinect;
  const std::vector<std::uint8_t> shadow =
      kp.projector_shadows
          ? projectorShadows(hits, k.width, k.fx, kp.projector_baseline_m)
          : std::vector<std::uint8_t>(static_cast<std::size_t>(k.width) * k.height, 0);
  allocateImages(frame, truth);
  const cv::Mat holes = holeMask();
  const bool flying = kp.flying_pixel_rate > 0.0;
  // Light from above and a little from the camera's side, fixed in the world.
  const Eigen::Vector3f light =
      (world_from_camera.linear().transpose() * Eigen::Vector3d(0.3, -0.5, 1.0).normalized())
          .cast<float>();

  for (int v = 0; v < k.height; ++v) {
    auto* depth_row = frame.depth.ptr<std::uint16_t>(v);
    auto* surface_row = truth.surface_labels.ptr<std::uint16_t>(v);
    auto* object_row = truth.object_labels.ptr<std::uint16_t>(v);
    auto* ideal_row = truth.ideal_depth.ptr<float>(v);
    auto* rgb_row = params_.render_colour ? frame.rgb.ptr<cv::Vec3b>(v) : nullptr;
    const double ray_y = (v - k.cy) / k.fy;
    for (int u = 0; u < k.width; ++u) {
      const std::size_t i = hits.index(u, v);
      const double z = hits.depth[i];
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3f& n = hits.normal[i];
      const std::size_t pixel = static_cast<std::size_t>(v) * k.width + u;
      if (rgb_row) rgb_row[u] = shade(hits.surface[i], n, light, noise_.bits(pixel, kColourDraw));
      if (z < kp.min_range_m || z > kp.max_range_m) continue;
      ideal_row[u] = static_cast<float>(z);
      if (shadow[pixel]) continue;
      if (!holes.empty() && holes.at<std::uint8_t>(v, u)) continue;
      const Eigen::Vector3f ray =
          Eigen::Vector3f(static_cast<float>((u - k.cx) / k.fx), static_cast<float>(ray_y), 1.0f)
              .normalized();
      const double measured =
          reading(pixel, flying ? flyingDepth(hits, u, v, pixel, z) : z, n, ray);
      if (measured == 0.0) continue;
      depth_row[u] =
          static_cast<std::uint16_t>(measured * 1000.0 + 0.5);  // positive: round half up
      surface_row[u] = hits.surface[i];
      object_row[u] = hits.object[i];
    }
  }
}

cv::Mat SensorModel::holeMask() const {
  const KinectParams& kp = params_.kinect;
  if (kp.holes_max <= 0) return {};
  const CameraIntrinsics& k = params_.intrinsics;
  Rng rng(mix64(artefacts_.bits(0, kHoleDraw)));
  cv::Mat mask = cv::Mat::zeros(k.height, k.width, CV_8UC1);
  const int count = rng.uniformInt(kp.holes_min, kp.holes_max);
  for (int h = 0; h < count; ++h) {
    const Eigen::Vector2d centre = rng.uniform2({0.0, 0.0}, {k.width, k.height});
    const int parts = rng.uniformInt(1, 3);
    for (int p = 0; p < parts; ++p) {
      const Eigen::Vector2d at =
          centre + 0.5 * kp.hole_radius_max_px * rng.uniform2({-1.0, -1.0}, {1.0, 1.0});
      const Eigen::Vector2d radii = rng.uniform2(Eigen::Vector2d::Constant(kp.hole_radius_min_px),
                                                 Eigen::Vector2d::Constant(kp.hole_radius_max_px));
      const cv::Size axes(static_cast<int>(std::lround(radii.x())),
                          static_cast<int>(std::lround(radii.y())));
      const double angle = rng.uniform(0.0, 180.0);
      cv::ellipse(
          mask,
          cv::Point(static_cast<int>(std::lround(at.x())), static_cast<int>(std::lround(at.y()))),
          axes, angle, 0.0, 360.0, cv::Scalar(255), cv::FILLED, cv::LINE_8);
    }
  }
  return mask;
}

double SensorModel::flyingDepth(const HitBuffer& hits, int u, int v, std::size_t pixel,
                                double z) const {
  const KinectParams& kp = params_.kinect;
  double other = z, jump = kp.flying_pixel_min_jump_m;
  constexpr std::array<int, 4> kDu = {-1, 1, 0, 0}, kDv = {0, 0, -1, 1};
  for (std::size_t k = 0; k < 4; ++k) {
    const int nu = u + kDu[k], nv = v + kDv[k];
    if (nu < 0 || nv < 0 || nu >= hits.width || nv >= hits.height) continue;
    const double zn = hits.depth[hits.index(nu, nv)];
    if (zn < kp.min_range_m || zn > kp.max_range_m || std::abs(zn - z) <= jump) continue;
    jump = std::abs(zn - z), other = zn;
  }
  if (other == z || artefacts_.uniform(pixel, kFlyingDraw) >= kp.flying_pixel_rate) return z;
  return z + artefacts_.uniform(pixel, kFlyingDraw + 1) * (other - z);
}

void SensorModel::allocateImages(Frame& frame, TruthFrame& truth) const {
  const CameraIntrinsics& k = params_.intrinsics;
  frame.depth = cv::Mat::zeros(k.height, k.width, CV_16UC1);
  truth.surface_labels = cv::Mat::zeros(k.height, k.width, CV_16UC1);
  truth.object_labels = cv::Mat::zeros(k.height, k.width, CV_16UC1);
  truth.ideal_depth = cv::Mat::zeros(k.height, k.width, CV_32FC1);
  if (params_.render_colour) frame.rgb = cv::Mat::zeros(k.height, k.width, CV_8UC3);
}

double SensorModel::reading(std::size_t pixel, double z, const Eigen::Vector3f& n,
                            const Eigen::Vector3f& ray) const {
  const KinectParams& kp = params_.kinect;
  if (std::abs(n.dot(ray)) < cos_max_incidence_) return 0.0;
  if (noise_.uniform(pixel, kDropoutDraw) < kp.dropout_rate) return 0.0;
  const double measured = measure(z, noise_.normal(pixel, kDisparityDraw));
  if (measured < kp.min_range_m || measured > kp.max_range_m) return 0.0;
  return measured;
}

double SensorModel::measure(double z, double standard_normal) const {
  const KinectParams& kp = params_.kinect;
  const double disparity = kp.focal_baseline_px_m / z + kp.disparity_noise_px * standard_normal;
  if (disparity <= 0.0) return 0.0;
  // Round half up by truncation (cheaper than std::round; the value is positive).
  const double quantised =
      static_cast<double>(static_cast<std::int64_t>(disparity / kp.disparity_step_px + 0.5)) *
      kp.disparity_step_px;
  return quantised > 0.0 ? kp.focal_baseline_px_m / quantised : 0.0;
}

cv::Vec3b SensorModel::shade(std::uint16_t surface, const Eigen::Vector3f& normal,
                             const Eigen::Vector3f& light, std::uint64_t bits) const {
  const Eigen::Vector3f& base = model_.surfaces[surface - 1].colour_bgr;
  const float lambert = std::max(0.0f, normal.dot(light));
  cv::Vec3b out;
  for (int c = 0; c < 3; ++c) {
    const float noise = static_cast<float>((bits >> (8 * c)) & 0x7) - 3.5f;  // +-3.5 levels
    out[c] = cv::saturate_cast<std::uint8_t>(base[c] * (0.55f + 0.45f * lambert) + noise);
  }
  return out;
}

}  // namespace shapesense::synthetic::detail
