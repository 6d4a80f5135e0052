#include "shapesense/core/planes/plane_accumulator.h"

#include <algorithm>
#include <cmath>

#include "shapesense/core/geometry/units.h"

namespace shapesense {
namespace {

// A point on a detected plane near its inliers: the polygon's vertex mean, else the foot of
// the perpendicular from the camera.
Eigen::Vector3d pointOn(const DetectedPlane& p) {
  if (p.polygon.size() >= 3) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& v : p.polygon) c += v;
    c /= static_cast<double>(p.polygon.size());
    return c - (p.normal.dot(c) + p.d) * p.normal;  // project (vertices are on it already)
  }
  return -p.d * p.normal;
}

}  // namespace

PlaneAccumulator::PlaneAccumulator(PlaneAccumulatorParams params)
    : params_(params), space_(params.space) {}

void PlaneAccumulator::reset() {
  space_.clear();
  tracks_.clear();
  world_from_ref_.reset();
  ref_from_camera_ = Eigen::Isometry3d::Identity();
  ++resets_;
}

int PlaneAccumulator::matchTrack(const Eigen::Vector3d& n, double d) const {
  const double cos_gate = std::cos(degToRad(params_.match_angle_deg));
  int best = -1;
  double best_cost = 1e30;
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    const Eigen::Vector3d tn = tracks_[t].normal();
    const double c = tn.dot(n);
    if (c < cos_gate) continue;
    const double dd = std::fabs(tracks_[t].d() - d);
    if (dd > params_.match_distance_m) continue;
    const double cost = dd / params_.match_distance_m + (1.0 - c) / (1.0 - cos_gate + 1e-12);
    if (cost < best_cost) {
      best_cost = cost;
      best = static_cast<int>(t);
    }
  }
  return best;
}

void PlaneAccumulator::update(const PlaneDetection& frame,
                              const std::optional<Eigen::Isometry3d>& world_from_camera) {
  // 1. Reference frame and reset rules (see header).
  if (world_from_camera) {
    if (!had_pose_ && frames_ > 0) reset();
    if (!world_from_ref_) world_from_ref_ = *world_from_camera;
    ref_from_camera_ = world_from_ref_->inverse() * *world_from_camera;
    const double angle = Eigen::AngleAxisd(ref_from_camera_.rotation()).angle();
    if (angle > degToRad(params_.max_rotation_deg)) {
      reset();
      world_from_ref_ = *world_from_camera;
      ref_from_camera_ = Eigen::Isometry3d::Identity();
    }
    had_pose_ = true;
  } else {
    if (had_pose_) reset();
    had_pose_ = false;
    ref_from_camera_ = Eigen::Isometry3d::Identity();
    const double min_w = params_.min_frames * 0.5;
    int established = 0;
    for (const auto& t : tracks_)
      established += t.weight > 0 && t.last.inliers > 0 && t.weight >= min_w;
    if (established >= params_.reset_min_planes) {
      double total = 0, matched = 0;
      for (const auto& p : frame.planes) {
        total += static_cast<double>(p.inliers);
        const int t = matchTrack(p.normal, p.d);
        if (t >= 0) matched += static_cast<double>(p.inliers);
      }
      if (total > 0 && matched < params_.reset_matched_fraction * total) reset();
    }
  }
  ++frames_;

  // 2. Decay ("thinning") of the space and the tracks.
  space_.decay(params_.decay, params_.thinning);
  for (auto& t : tracks_) {
    t.sum_normal *= params_.decay;
    t.sum_point *= params_.decay;
    t.weight *= params_.decay;
  }
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& t) { return t.weight < 1e-3; }),
                tracks_.end());

  // 3. Add the frame's planes in the reference frame.
  const Eigen::Matrix3d R = ref_from_camera_.rotation();
  const Eigen::Vector3d tr = ref_from_camera_.translation();
  for (const auto& p : frame.planes) {
    Eigen::Vector3d n = R * p.normal;
    const Eigen::Vector3d x = R * pointOn(p) + tr;
    double d = -n.dot(x);
    if (d < 0) continue;  // the reference camera is behind this plane: not representable
    space_.addGaussian(n, d, 1.0, params_.sigma_angle_deg, params_.sigma_d_m);
    const double w = static_cast<double>(std::max<std::size_t>(1, p.inliers));
    int t = matchTrack(n, d);
    if (t < 0) {
      tracks_.emplace_back();
      tracks_.back().id = next_id_;
      next_id_ = static_cast<std::uint16_t>(next_id_ == 65535 ? 1 : next_id_ + 1);
      t = static_cast<int>(tracks_.size()) - 1;
    }
    Track& tk = tracks_[t];
    // Weights are relative within a track (normalised per frame by the track's own scale), so
    // a large plane's average is not dominated by one frame with a few more inliers.
    tk.sum_normal += w * n;
    tk.sum_point += w * x;
    tk.weight += w;
    tk.last = p;
    tk.ref_from_last = ref_from_camera_;
  }
}

std::vector<DetectedPlane> PlaneAccumulator::planes() const {
  std::vector<DetectedPlane> out;
  const double min_peak =
      params_.min_frames * space_.kernelPeak(params_.sigma_angle_deg, params_.sigma_d_m);
  const auto maxima = space_.findMaxima(static_cast<float>(min_peak), 2, 2);
  const Eigen::Isometry3d camera_from_ref = ref_from_camera_.inverse();
  std::vector<bool> used(tracks_.size(), false);
  for (const auto& m : maxima) {
    const int t = matchTrack(m.normal, m.d);
    if (t < 0 || used[t]) continue;
    used[t] = true;
    const Track& tk = tracks_[t];
    DetectedPlane p = tk.last;
    p.id = tk.id;
    p.group = tk.id;
    Eigen::Vector3d n = camera_from_ref.rotation() * tk.normal();
    const Eigen::Vector3d x = camera_from_ref * (tk.sum_point / tk.weight);
    double d = -n.dot(x);
    if (d < 0) {
      n = -n;
      d = -d;
    }
    p.normal = n;
    p.d = d;
    const Eigen::Isometry3d camera_from_last = camera_from_ref * tk.ref_from_last;
    for (auto& v : p.polygon) v = camera_from_last * v;
    out.push_back(std::move(p));
  }
  std::sort(out.begin(), out.end(),
            [](const DetectedPlane& a, const DetectedPlane& b) { return a.id < b.id; });
  return out;
}

}  // namespace shapesense
