#pragma once
// The solids the layout places: one class per shape, defined in <shape>_solid(s).cpp.

#include <array>
#include <string>

#include "solid.h"

namespace shapesense::synthetic::detail {

/// A box centred on the origin. Faces 0..5 = -x, +x, -y, +y, -z, +z, named by `face_names`
/// (by default "_face_left", "_face_right", "_face_front", "_face_back", "_face_bottom",
/// "_face_top": front is the box's local -y).
class BoxSolid final : public Solid {
 public:
  using FaceNames = std::array<std::string, 6>;
  static FaceNames defaultFaceNames();

  explicit BoxSolid(Eigen::Vector3d half, FaceNames face_names = defaultFaceNames());
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  Eigen::Vector3d half_;
  FaceNames face_names_;
};

/// The inside of a box (the room): the ray leaves it through one face. Faces as BoxSolid,
/// named "wall_left", "wall_right", "wall_front", "wall_back", "floor", "ceiling".
class RoomSolid final : public Solid {
 public:
  enum Face { kWallLeft, kWallRight, kWallFront, kWallBack, kFloor, kCeiling };
  explicit RoomSolid(Eigen::Vector3d half);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  Eigen::Vector3d half_;
};

/// A spherical-cap shell: the ball of radius `radius` below the rim plane z = rim_z (<= 0),
/// minus the concentric ball of radius radius - thickness. Origin at the sphere centre, z
/// towards the opening.
class BowlSolid final : public Solid {
 public:
  enum Face { kOuter, kRim, kInner };
  BowlSolid(double radius, double rim_z, double thickness);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  double radius_;
  double rim_z_;
  double inner_radius_;
};

/// An open cylinder (cup): outer radius, height, wall and bottom thickness. Origin at the
/// centre of the bottom, z up.
class CupSolid final : public Solid {
 public:
  enum Face { kOuter, kBottom, kRim, kInner, kInnerBottom };
  CupSolid(double radius, double height, double wall, double bottom);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  double radius_;
  double height_;
  double inner_radius_;
  double bottom_;
};

/// A closed cylinder (tin). Origin at the centre of the bottom, z up.
class TinSolid final : public Solid {
 public:
  enum Face { kSide, kBottom, kTop };
  TinSolid(double radius, double height);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  double radius_;
  double height_;
};

/// A sphere centred on the origin; its one face is named after the object.
class BallSolid final : public Solid {
 public:
  explicit BallSolid(double radius);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  double radius_;
};

}  // namespace shapesense::synthetic::detail
