// Boxes seen from outside (boxes, table parts) and from inside (the room).

#include <utility>

#include "solids.h"

namespace shapesense::synthetic::detail {

namespace {

/// Face f of an axis-aligned box of half extents `half` as a plane label (-x, +x, -y, +y, -z, +z).
FaceLabel boxFace(int f, const Eigen::Vector3d& half, std::string name) {
  const Eigen::Vector3d n = axisNormal(f);
  return {std::move(name), SurfaceKind::kPlane, n, n.cwiseProduct(half)};
}

}  // namespace

BoxSolid::FaceNames BoxSolid::defaultFaceNames() {
  return {"_face_left", "_face_right", "_face_front", "_face_back", "_face_bottom", "_face_top"};
}

BoxSolid::BoxSolid(Eigen::Vector3d half, FaceNames face_names)
    : half_(std::move(half)), face_names_(std::move(face_names)) {}

bool BoxSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const {
  const Span s = boxSpan(o, d, half_);
  if (s.empty() || s.t0 <= 0.0) return false;
  hit.t = s.t0, hit.face = s.face0, hit.normal = axisNormal(s.face0);
  return true;
}

Eigen::AlignedBox3d BoxSolid::bounds() const { return {-half_, half_}; }

std::vector<FaceLabel> BoxSolid::faces() const {
  std::vector<FaceLabel> labels;
  for (int f = 0; f < 6; ++f) labels.push_back(boxFace(f, half_, face_names_[f]));
  return labels;
}

RoomSolid::RoomSolid(Eigen::Vector3d half) : half_(std::move(half)) {}

bool RoomSolid::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const {
  const Span s = boxSpan(o, d, half_);
  if (s.empty() || s.t1 <= 0.0) return false;
  hit.t = s.t1, hit.face = s.face1, hit.normal = -axisNormal(s.face1);
  return true;
}

Eigen::AlignedBox3d RoomSolid::bounds() const { return {-half_, half_}; }

std::vector<FaceLabel> RoomSolid::faces() const {
  // The room has no name of its own, so these are the whole surface names.
  const std::array<const char*, 6> names = {"wall_left", "wall_right", "wall_front",
                                            "wall_back", "floor",      "ceiling"};
  std::vector<FaceLabel> labels;
  for (int f = 0; f < 6; ++f) labels.push_back(boxFace(f, half_, names[f]));
  return labels;
}

}  // namespace shapesense::synthetic::detail
