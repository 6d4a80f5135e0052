// Curved solids without a closed-form span: the torus (sphere tracing) and the smooth mound
// (a height field, marched and bisected).

#include <algorithm>
#include <cmath>
#include <utility>

#include "solids.h"

namespace shapesense::synthetic::detail {

TorusSolid::TorusSolid(double major, double tube) : major_(major), tube_(tube) {}

bool TorusSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                           LocalHit& hit) const {
  const Eigen::Vector3d half(major_ + tube_, major_ + tube_, tube_);
  const Span box = boxSpan(o, d, half);
  if (box.empty() || box.t1 <= 0.0) return false;
  const double speed = d.norm();
  const auto distance = [&](const Eigen::Vector3d& p) {
    return std::hypot(std::hypot(p.x(), p.y()) - major_, p.z()) - tube_;
  };
  double t = std::max(box.t0, 0.0);
  for (int step = 0; step < 400 && t <= box.t1; ++step) {
    const Eigen::Vector3d p = o + t * d;
    const double dist = distance(p);
    if (dist < 1e-9) {
      if (t <= 0.0) return false;  // starts inside
      const double radial = std::hypot(p.x(), p.y());
      const Eigen::Vector3d ring = radial > 0.0
                                       ? Eigen::Vector3d(p.x(), p.y(), 0.0) * (major_ / radial)
                                       : Eigen::Vector3d(major_, 0.0, 0.0);
      hit.t = t, hit.face = 0, hit.normal = (p - ring).normalized();
      return true;
    }
    t += dist / speed;
  }
  return false;
}

Eigen::AlignedBox3d TorusSolid::bounds() const {
  const Eigen::Vector3d half(major_ + tube_, major_ + tube_, tube_);
  return {-half, half};
}

std::vector<FaceLabel> TorusSolid::faces() const { return {{"", SurfaceKind::kCurved}}; }

MoundSolid::MoundSolid(Eigen::Vector2d half, double height, std::vector<Bump> bumps)
    : half_(std::move(half)),
      height_(height),
      grid_peak_(0.0),
      peak_(0.0),
      bumps_(std::move(bumps)) {
  // The peak from a fine grid, with a margin for what lies between the grid points.
  for (int i = 0; i <= 64; ++i)
    for (int j = 0; j <= 64; ++j)
      grid_peak_ = std::max(grid_peak_,
                            heightAt(half_.x() * (i / 32.0 - 1.0), half_.y() * (j / 32.0 - 1.0)));
  peak_ = grid_peak_ * 1.05 + 1e-4;
}

double MoundSolid::heightAt(double x, double y) const {
  const double u = x / half_.x(), v = y / half_.y();
  if (std::abs(u) >= 1.0 || std::abs(v) >= 1.0) return 0.0;
  const double window = (1.0 - u * u) * (1.0 - u * u) * (1.0 - v * v) * (1.0 - v * v);
  double sum = 0.0;
  for (const Bump& b : bumps_) {
    const double du = u - b.center.x(), dv = v - b.center.y();
    sum += b.weight * std::exp(-(du * du + dv * dv) / (2.0 * b.sigma * b.sigma));
  }
  return height_ * window * sum;
}

bool MoundSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                           LocalHit& hit) const {
  // The box from z = 0 to the peak.
  Span s = slabSpan(o.x(), d.x(), -half_.x(), half_.x(), -1, -1);
  s = intersectSpans(s, slabSpan(o.y(), d.y(), -half_.y(), half_.y(), -1, -1));
  s = intersectSpans(s, slabSpan(o.z(), d.z(), 0.0, peak_, kBase, -1));
  if (s.empty() || s.t1 <= 0.0) return false;
  const auto above = [&](double t) {
    const Eigen::Vector3d p = o + t * d;
    return p.z() - heightAt(p.x(), p.y());
  };
  const double t_start = std::max(s.t0, 0.0);
  if (s.face0 == kBase && s.t0 > 0.0 && heightAt((o + s.t0 * d).x(), (o + s.t0 * d).y()) > 0.0) {
    hit.t = s.t0, hit.face = kBase, hit.normal = -Eigen::Vector3d::UnitZ();  // from below
    return true;
  }
  if (above(t_start) <= 0.0) return false;  // starts inside
  constexpr int kSteps = 96;
  const double step = (s.t1 - t_start) / kSteps;
  double t0 = t_start;
  for (int i = 1; i <= kSteps; ++i) {
    const double t1 = t_start + i * step;
    if (above(t1) > 0.0) {
      t0 = t1;
      continue;
    }
    double lo = t0, hi = t1;  // above(lo) > 0 >= above(hi)
    const double speed = d.norm();
    for (int k = 0; k < 80 && (hi - lo) * speed > 1e-9; ++k) {
      const double mid = 0.5 * (lo + hi);
      (above(mid) > 0.0 ? lo : hi) = mid;
    }
    const Eigen::Vector3d p = o + hi * d;
    const double e = 1e-6;
    const double hx = (heightAt(p.x() + e, p.y()) - heightAt(p.x() - e, p.y())) / (2 * e);
    const double hy = (heightAt(p.x(), p.y() + e) - heightAt(p.x(), p.y() - e)) / (2 * e);
    hit.t = hi, hit.face = kTop, hit.normal = Eigen::Vector3d(-hx, -hy, 1.0).normalized();
    return true;
  }
  return false;
}

Eigen::AlignedBox3d MoundSolid::bounds() const {
  return {Eigen::Vector3d(-half_.x(), -half_.y(), 0.0),
          Eigen::Vector3d(half_.x(), half_.y(), peak_)};
}

std::vector<FaceLabel> MoundSolid::faces() const {
  std::vector<FaceLabel> labels(2);
  labels[kTop] = {"_top", SurfaceKind::kCurved};
  labels[kBase] = {"_base", SurfaceKind::kPlane, -Eigen::Vector3d::UnitZ(),
                   Eigen::Vector3d::Zero()};
  return labels;
}

}  // namespace shapesense::synthetic::detail
