#pragma once
// A solid of the scene in its own frame. Each solid type keeps in one place what the renderer
// needs (its ray intersection and bounds) and what the ground truth needs (a label per face),
// so a new kind of object is one new Solid plus one layout step that places it.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ray_span.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::synthetic::detail {

struct LocalHit {
  double t = kInf;
  int face = -1;
  Eigen::Vector3d normal;  ///< unit, local frame, pointing out of the material (towards the ray)
};

/// What the surface made from one face of a solid is called, and what it is.
struct FaceLabel {
  std::string name;  ///< appended to the owning object's name: "_inner" gives "bowl2_inner"
  SurfaceKind kind = SurfaceKind::kCurved;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< kPlane only: local, either orientation
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< kPlane only: a local point on the face
  float shade = 1.0f;  ///< colour relative to the object's (rims lighter, insides darker)
};

class Solid {
 public:
  virtual ~Solid() = default;
  /// The first surface point o + t d with t > 0, if any. hit.face indexes faces().
  virtual bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                         LocalHit& hit) const = 0;
  virtual Eigen::AlignedBox3d bounds() const = 0;
  /// One label per face that intersect() can report, in face order (= surface id order).
  virtual std::vector<FaceLabel> faces() const = 0;
};

}  // namespace shapesense::synthetic::detail
