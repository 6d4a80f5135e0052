#pragma once
// LayoutBuilder: draws a plausible random scene from SceneParams. Its steps live in one file per
// part of the scene:
//   layout.cpp            the outline (what is added in which order) and the model bookkeeping
//   layout_room.cpp       camera and table placement, the room around them
//   layout_table.cpp      the table
//   layout_objects.cpp    boxes, bowls, cups, tins and balls
//   layout_placement.cpp  free spots on the table top and the floor
//   layout_free_look.cpp  the free-look camera, table and drawn room size (SceneParams::free_look)
//   layout_extras.cpp     the wider distribution's additions: more, stacked and touching boxes,
//                         thin objects, lying tins, bins, columns, tori, mounds
//   layout_shelves.cpp    shelf units against a wall
//
// A new kind of object is a Solid (solids.h) and an add*() step that draws its size, takes a
// spot from tableSpot() or floorSpot() and hands the solid to addShadedSolid(); its surfaces and
// their truth come from the solid's face labels.
//
// The order of random draws is part of the scene definition: changing it (or adding a draw
// anywhere but at the end of build()) changes every scene, and with it the test fixtures.
// The optional additions (layout_extras.cpp, layout_shelves.cpp, the extra camera roll) draw
// from a second generator (withExtraStream) so that they never move a draw of the first.

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "random.h"
#include "scene_model.h"
#include "shapesense/driver/synthetic_scene.h"
#include "solids.h"

namespace shapesense::synthetic::detail {

/// A circle that must stay clear of others on the same support surface.
struct Footprint {
  Eigen::Vector2d center;
  double radius = 0.0;
};

/// A rectangle on the floor that floor objects placed later keep clear of (table, shelves).
struct FloorBlock {
  Eigen::Vector2d center;
  double yaw = 0.0;
  Eigen::Vector2d half;
};

/// A horizontal face objects can be set on: the top of a box or a shelf board.
struct Support {
  Eigen::Isometry3d top;   ///< centre of the face, z up, x and y along its sides
  Eigen::Vector2d half;    ///< half extents of the face
  double clearance = 1e9;  ///< free height above it (m)
  std::vector<Footprint> taken;
};

/// `bgr` scaled by a factor drawn from [1 - amount, 1 + amount], capped at 255.
Eigen::Vector3f jitterColour(Rng& rng, Eigen::Vector3f bgr, double amount);

/// Generates the layout from the seed. One object per call of an add*() step.
class LayoutBuilder {
 public:
  explicit LayoutBuilder(const SceneParams& params);
  std::unique_ptr<const SceneModel> build();

 private:
  /// The colour of face `face` (labelled `label`) of a solid being added.
  using FaceColour = std::function<Eigen::Vector3f(int face, const FaceLabel& label)>;

  // layout.cpp: the bookkeeping every step shares.
  void addSeveral(int min_count, int max_count, void (LayoutBuilder::*add)());
  std::uint16_t addSurface(std::string name, SurfaceKind kind, const Eigen::Vector4d& plane,
                           std::uint16_t object_id, const Eigen::Vector3f& colour);
  std::uint16_t addObject(const ObjectDef& object);
  /// Places `solid` at `pose` and makes each of its faces a surface named `name_prefix` + the
  /// face's label, coloured by `colour_of` (called in face order: it may draw).
  void addSolid(std::unique_ptr<const Solid> solid, const Eigen::Isometry3d& pose,
                std::uint16_t object_id, const std::string& name_prefix,
                const FaceColour& colour_of);
  /// addSolid with `colour` shaded per face as the solid's labels say.
  void addShadedSolid(std::unique_ptr<const Solid> solid, const ObjectDef& object,
                      std::uint16_t object_id, const Eigen::Vector3f& colour);
  /// A box of half extents `half` whose faces each get `colour` jittered a little.
  void addBoxSolid(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half,
                   std::uint16_t object_id, const std::string& name_prefix,
                   const Eigen::Vector3f& colour,
                   BoxSolid::FaceNames face_names = BoxSolid::defaultFaceNames());
  /// A colour from the object palette, jittered.
  Eigen::Vector3f objectColour();
  /// "<kind><n>": the n-th object of that kind (box1, box2, ..., bowl1, ...).
  std::string nextObjectName(const std::string& kind);
  /// An object made of one solid: its local box is the solid's bounds, its faces are
  /// addShadedSolid's with `colour`. Returns the object's id.
  std::uint16_t addSolidObject(ObjectDef object, std::unique_ptr<const Solid> solid,
                               const Eigen::Vector3f& colour);

  // layout_room.cpp
  void placeCameraAndTable();
  void addRoom();
  void drawRoomExtent(Eigen::Vector3d& half, Eigen::Isometry3d& world_from_room);
  int visibleWalls(const RoomSolid& room, const Eigen::Isometry3d& world_from_room) const;

  // layout_table.cpp
  void addTable();

  // layout_objects.cpp
  void addTableBox();
  void addFloorBox();
  void addBox(const Eigen::Isometry3d& support, const Eigen::Vector3d& size);
  void addBowl();
  void addCup();
  void addTin();
  void addBall();

  // layout_free_look.cpp
  void placeFreeLookCamera();
  void drawRoomSize(Eigen::Vector3d& half, Eigen::Isometry3d& world_from_room);

  // layout_extras.cpp
  /// Runs `step` with rng_ drawing from the extra stream (and restores the main stream).
  template <typename Step>
  void withExtraStream(Step step) {
    std::swap(rng_, extra_rng_);
    step();
    std::swap(rng_, extra_rng_);
  }
  bool anyExtras() const;
  void addExtras();
  void addCameraRoll();
  void addExtraBox();
  void addTouchingBoxPair();
  void addStackedBox();
  void addThinObject();
  void addLyingTin();
  void addBin();
  void addColumn();
  void addTorus();
  void addMound();
  /// addBox that also records the box's top as a support. Returns the box's object id.
  std::uint16_t addSupportingBox(const Eigen::Isometry3d& support, const Eigen::Vector3d& size,
                                 double clearance = 1e9);
  /// A free spot for a footprint of `radius` on a support with at least `height` of clearance.
  std::optional<Eigen::Isometry3d> supportSpot(Support& support, double radius, double height);
  /// A free floor spot anywhere in the room and in view, clear of the floor blocks.
  std::optional<Eigen::Isometry3d> openFloorSpot(double radius, double height);
  bool clearOfBlocks(const Eigen::Vector2d& c, double radius) const;
  bool inView(const Eigen::Vector3d& world_point, double margin_px) const;

  // layout_shelves.cpp
  void addShelf();

  // layout_placement.cpp
  std::optional<Eigen::Isometry3d> tableSpot(double radius);
  std::optional<Eigen::Isometry3d> floorSpot(double radius, double height);
  std::optional<Eigen::Vector2d> floorCandidate(double radius, double height);
  static bool isFree(const std::vector<Footprint>& taken, const Eigen::Vector2d& c, double radius);

  const SceneParams& params_;
  Rng rng_;
  std::unique_ptr<SceneModel> model_;
  Eigen::Vector3d camera_position_ = Eigen::Vector3d::Zero();
  Eigen::Vector2d table_center_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d table_size_ = Eigen::Vector2d::Ones();
  double table_height_ = 0.7;
  double table_yaw_ = 0.0;
  Eigen::Vector2d room_min_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d room_max_ = Eigen::Vector2d::Zero();
  std::vector<Footprint> table_footprints_;
  std::vector<Footprint> floor_footprints_;
  std::map<std::string, int> objects_of_kind_;  // for the names: box1, box2, ..., bowl1, ...

  // The wider distribution's additions.
  Rng extra_rng_;
  double room_height_ = 0.0;
  std::vector<FloorBlock> floor_blocks_;
  std::vector<Support> box_tops_;
};

}  // namespace shapesense::synthetic::detail
