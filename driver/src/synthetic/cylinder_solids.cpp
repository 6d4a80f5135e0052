// Solids bounded by a cylinder about the local z axis: cups (open) and tins (closed).

#include "solids.h"

namespace shapesense::synthetic::detail {

namespace {

/// The outward normal of a cylinder of radius r about the local z axis at its point p.
Eigen::Vector3d radialNormal(const Eigen::Vector3d& p, double r) {
  return Eigen::Vector3d(p.x(), p.y(), 0.0) / r;
}

}  // namespace

CupSolid::CupSolid(double radius, double height, double wall, double bottom)
    : radius_(radius), height_(height), inner_radius_(radius - wall), bottom_(bottom) {}

bool CupSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const {
  const Span outer = intersectSpans(cylinderSpan(o, d, radius_, kOuter),
                                    slabSpan(o.z(), d.z(), 0.0, height_, kBottom, kRim));
  if (outer.empty()) return false;
  // The cavity reaches above the rim so that it opens the top face.
  const Span cavity =
      intersectSpans(cylinderSpan(o, d, inner_radius_, kInner),
                     slabSpan(o.z(), d.z(), bottom_, height_ + 1.0, kInnerBottom, -1));
  if (!firstEntryOfDifference(outer, cavity, hit.t, hit.face)) return false;
  const Eigen::Vector3d p = o + hit.t * d;
  switch (hit.face) {
    case kOuter:
      hit.normal = radialNormal(p, radius_);
      break;
    case kBottom:
      hit.normal = -Eigen::Vector3d::UnitZ();
      break;
    case kInner:
      hit.normal = -radialNormal(p, inner_radius_);
      break;
    default:
      hit.normal = Eigen::Vector3d::UnitZ();
      break;  // rim, inner bottom
  }
  return true;
}

Eigen::AlignedBox3d CupSolid::bounds() const {
  return {Eigen::Vector3d(-radius_, -radius_, 0.0), Eigen::Vector3d(radius_, radius_, height_)};
}

std::vector<FaceLabel> CupSolid::faces() const {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<FaceLabel> labels(5);
  labels[kOuter] = {"_outer", SurfaceKind::kCurved};
  labels[kBottom] = {"_bottom", SurfaceKind::kPlane, -up, Eigen::Vector3d::Zero()};
  labels[kRim] = {"_rim", SurfaceKind::kPlane, up, height_ * up, 1.05f};
  labels[kInner] = {"_inner", SurfaceKind::kCurved, Eigen::Vector3d::Zero(),
                    Eigen::Vector3d::Zero(), 0.9f};
  labels[kInnerBottom] = {"_inner_bottom", SurfaceKind::kPlane, up, bottom_ * up, 0.8f};
  return labels;
}

TinSolid::TinSolid(double radius, double height) : radius_(radius), height_(height) {}

bool TinSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const {
  const Span s = intersectSpans(cylinderSpan(o, d, radius_, kSide),
                                slabSpan(o.z(), d.z(), 0.0, height_, kBottom, kTop));
  if (s.empty() || s.t0 <= 0.0) return false;
  hit.t = s.t0, hit.face = s.face0;
  const Eigen::Vector3d p = o + hit.t * d;
  switch (hit.face) {
    case kSide:
      hit.normal = radialNormal(p, radius_);
      break;
    case kBottom:
      hit.normal = -Eigen::Vector3d::UnitZ();
      break;
    default:
      hit.normal = Eigen::Vector3d::UnitZ();
      break;
  }
  return true;
}

Eigen::AlignedBox3d TinSolid::bounds() const {
  return {Eigen::Vector3d(-radius_, -radius_, 0.0), Eigen::Vector3d(radius_, radius_, height_)};
}

std::vector<FaceLabel> TinSolid::faces() const {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<FaceLabel> labels(3);
  labels[kSide] = {"_side", SurfaceKind::kCurved};
  labels[kBottom] = {"_bottom", SurfaceKind::kPlane, -up, Eigen::Vector3d::Zero()};
  labels[kTop] = {"_top", SurfaceKind::kPlane, up, height_ * up, 1.1f};
  return labels;
}

}  // namespace shapesense::synthetic::detail
