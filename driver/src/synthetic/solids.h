#pragma once
// The solids the layout places: one class per shape, defined in <shape>_solid(s).cpp.

#include <array>
#include <string>
#include <vector>

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

/// A torus about the local z axis centred on the origin: the points at distance `tube` from
/// the circle of radius `major` in the z = 0 plane. One curved face named after the object.
/// Intersected by sphere tracing its exact distance function (to 1e-9 m).
class TorusSolid final : public Solid {
 public:
  TorusSolid(double major, double tube);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;

 private:
  double major_;
  double tube_;
};

/// A smooth mound over the rectangle |x| <= half.x, |y| <= half.y: the solid between z = 0 and
/// the height field z = H(x, y) = height * window(x, y) * (sum of Gaussian bumps), where
/// window = (1 - (x/hx)^2)^2 (1 - (y/hy)^2)^2 takes H smoothly to 0 at the border. Faces:
/// kTop (the height field, curved) and kBase (z = 0, plane; it lies on what the mound rests
/// on). Intersected by marching the ray through the bounding box and bisecting the first sign
/// change of z - H (to 1e-9 m); features thinner than the march step (1/96 of the box chord)
/// may be missed at grazing incidence, and the truth follows the intersection.
class MoundSolid final : public Solid {
 public:
  enum Face { kTop, kBase };
  struct Bump {
    Eigen::Vector2d center;  ///< in units of half (-1..1)
    double sigma;            ///< in units of half
    double weight;
  };
  MoundSolid(Eigen::Vector2d half, double height, std::vector<Bump> bumps);
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::vector<FaceLabel> faces() const override;
  /// H(x, y); 0 outside the rectangle.
  double heightAt(double x, double y) const;
  /// The largest H on a 65 x 65 grid over the rectangle.
  double peakHeight() const { return grid_peak_; }

 private:
  Eigen::Vector2d half_;
  double height_;
  double grid_peak_;  ///< the largest H on the grid
  double peak_;       ///< above the largest H, for the bounds
  std::vector<Bump> bumps_;
};

}  // namespace shapesense::synthetic::detail
