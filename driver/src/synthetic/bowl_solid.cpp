#include <cmath>

#include "solids.h"

namespace shapesense::synthetic::detail {

BowlSolid::BowlSolid(double radius, double rim_z, double thickness)
    : radius_(radius), rim_z_(rim_z), inner_radius_(radius - thickness) {}

bool BowlSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const {
  const Span outer = intersectSpans(sphereSpan(o, d, radius_, kOuter),
                                    slabSpan(o.z(), d.z(), -kInf, rim_z_, -1, kRim));
  if (outer.empty()) return false;
  if (!firstEntryOfDifference(outer, sphereSpan(o, d, inner_radius_, kInner), hit.t, hit.face))
    return false;
  const Eigen::Vector3d p = o + hit.t * d;
  switch (hit.face) {
    case kOuter:
      hit.normal = p / radius_;
      break;
    case kRim:
      hit.normal = Eigen::Vector3d::UnitZ();
      break;
    default:
      hit.normal = -p / inner_radius_;
      break;
  }
  return true;
}

Eigen::AlignedBox3d BowlSolid::bounds() const {
  const double rim = std::sqrt(radius_ * radius_ - rim_z_ * rim_z_);
  return {Eigen::Vector3d(-rim, -rim, -radius_), Eigen::Vector3d(rim, rim, rim_z_)};
}

std::vector<FaceLabel> BowlSolid::faces() const {
  std::vector<FaceLabel> labels(3);
  labels[kOuter] = {"_outer", SurfaceKind::kCurved};
  labels[kRim] = {"_rim", SurfaceKind::kPlane, Eigen::Vector3d::UnitZ(), {0.0, 0.0, rim_z_}, 1.05f};
  labels[kInner] = {"_inner", SurfaceKind::kCurved, Eigen::Vector3d::Zero(),
                    Eigen::Vector3d::Zero(), 0.9f};
  return labels;
}

}  // namespace shapesense::synthetic::detail
