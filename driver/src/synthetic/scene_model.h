#pragma once
// The generated scene: what LayoutBuilder produces and what rendering and truth read. Ids are
// positions: surface id = index in `surfaces` + 1, object id = index in `objects` + 1, 0 =
// none (or the room, for objects).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "camera_pose.h"
#include "shapesense/driver/synthetic_scene.h"
#include "solid.h"

namespace shapesense::synthetic {

namespace detail {

struct SurfaceDef {
  std::string name;
  SurfaceKind kind = SurfaceKind::kPlane;
  Eigen::Vector4d world_plane = Eigen::Vector4d::Zero();  ///< any orientation
  std::uint16_t object_id = 0;
  Eigen::Vector3f colour_bgr = Eigen::Vector3f::Zero();  ///< 0..255
};

/// What a bowl's truth reports beyond its box. The bowl's object frame is the sphere centre,
/// z towards the opening.
struct BowlDef {
  bool upright = true;
  double rim_z = 0.0;
  double rim_radius = 0.0;
  double depth = 0.0;
  double thickness = 0.0;
};

struct ObjectDef {
  std::string kind;
  std::string name;
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();
  Eigen::AlignedBox3d local_box;  ///< tight bounds in the object frame
  std::optional<BowlDef> bowl;    ///< bowls only
};

/// A solid placed in the world; its faces map to scene surfaces.
struct Primitive {
  std::unique_ptr<const Solid> solid;
  Eigen::Isometry3d world_from_local = Eigen::Isometry3d::Identity();
  std::uint16_t object_id = 0;
  std::vector<std::uint16_t> surface_of_face;
};

}  // namespace detail

class SceneModel {
 public:
  std::vector<detail::SurfaceDef> surfaces;   ///< surface id = index + 1
  std::vector<detail::ObjectDef> objects;     ///< object id = index + 1
  std::vector<detail::Primitive> primitives;  ///< primitives[0] is the room
  Eigen::Isometry3d base_world_from_camera = Eigen::Isometry3d::Identity();
  detail::Sway sway;
};

}  // namespace shapesense::synthetic
