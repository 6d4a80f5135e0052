#include "solids.h"

namespace shapesense::synthetic::detail {

BallSolid::BallSolid(double radius) : radius_(radius) {}

bool BallSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const {
  const Span s = sphereSpan(o, d, radius_, 0);
  if (s.empty() || s.t0 <= 0.0) return false;
  hit.t = s.t0, hit.face = 0, hit.normal = (o + s.t0 * d) / radius_;
  return true;
}

Eigen::AlignedBox3d BallSolid::bounds() const {
  return {Eigen::Vector3d::Constant(-radius_), Eigen::Vector3d::Constant(radius_)};
}

std::vector<FaceLabel> BallSolid::faces() const { return {{"", SurfaceKind::kCurved}}; }

}  // namespace shapesense::synthetic::detail
