// Synthetic scene: layout generation (LayoutBuilder), analytic ray casting (Shape and its
// solids), the Kinect v1 sensor model (SensorModel) and ground truth (TruthBuilder).
//
// All solids are convex pieces or differences of two convex pieces (a bowl is a sphere cut by
// a plane minus a smaller sphere), so every ray/solid query reduces to intersecting parameter
// intervals along the ray. Rays are parameterised as X = t * (x/z, y/z, 1) in the camera
// frame, so the ray parameter t of the first hit IS the depth z.

#include "shapesense/driver/synthetic_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace shapesense::synthetic {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double degToRad(double deg) { return deg * std::numbers::pi / 180.0; }
double radToDeg(double rad) { return rad * 180.0 / std::numbers::pi; }

// ---------------------------------------------------------------------------------------------
// Random numbers. std::mt19937_64's output sequence is fixed by the standard, but the standard
// distributions are not, so the conversions are done here to keep scenes identical across
// standard libraries.

std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Separate streams so that, e.g., the noise of frame 3 never depends on the layout draws.
constexpr std::uint64_t kLayoutStream = 0x4C41594F5554ull;
constexpr std::uint64_t kFrameStream = 0x4652414D45ull;

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int uniformInt(int lo, int hi) {  // inclusive
    if (hi <= lo) return lo;
    return lo + static_cast<int>(engine_() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }

 private:
  std::mt19937_64 engine_;
};

/// Counter-based random numbers for the per-frame noise: a pixel's draws depend only on
/// (frame seed, pixel, draw), so the noise at one pixel never depends on which other pixels were
/// valid, and a change in one part of the model does not reshuffle the noise everywhere.
class PixelNoise {
 public:
  explicit PixelNoise(std::uint64_t frame_seed) : seed_(frame_seed) {}
  static constexpr unsigned kDrawsPerPixel = 8;

  std::uint64_t bits(std::size_t pixel, unsigned draw) const {
    return mix64(seed_ + pixel * kDrawsPerPixel + draw);
  }
  double uniform(std::size_t pixel, unsigned draw) const {
    return static_cast<double>(bits(pixel, draw) >> 11) * 0x1.0p-53;
  }
  /// A standard normal from draws first_draw .. kDrawsPerPixel - 1 (Marsaglia's polar method:
  /// no trigonometry; all but 1e-4 of the pixels accept within the available draws).
  double normal(std::size_t pixel, unsigned first_draw) const {
    for (unsigned draw = first_draw; draw < kDrawsPerPixel; ++draw) {
      const std::uint64_t b = bits(pixel, draw);
      const double x = static_cast<double>(b >> 32) * 0x1.0p-31 - 1.0;
      const double y = static_cast<double>(b & 0xFFFFFFFFu) * 0x1.0p-31 - 1.0;
      const double s = x * x + y * y;
      if (s > 0.0 && s < 1.0) return x * std::sqrt(-2.0 * std::log(s) / s);
    }
    const double u1 =
        (static_cast<double>(bits(pixel, first_draw) >> 11) + 1.0) * 0x1.0p-53;  // Box-Muller
    return std::sqrt(-2.0 * std::log(u1)) *
           std::cos(2.0 * std::numbers::pi * uniform(pixel, first_draw + 1));
  }

 private:
  std::uint64_t seed_;
};

// ---------------------------------------------------------------------------------------------
// Ray intervals. A convex solid occupies one interval [t0, t1] of a ray; face0/face1 name the
// surfaces through which the ray enters and leaves.

struct Span {
  double t0 = -kInf;
  double t1 = kInf;
  int face0 = -1;
  int face1 = -1;
  bool empty() const { return !(t0 < t1); }
};
constexpr Span kEmptySpan{kInf, -kInf, -1, -1};

Span intersectSpans(const Span& a, const Span& b) {
  Span r;
  if (a.t0 >= b.t0) {
    r.t0 = a.t0, r.face0 = a.face0;
  } else {
    r.t0 = b.t0, r.face0 = b.face0;
  }
  if (a.t1 <= b.t1) {
    r.t1 = a.t1, r.face1 = a.face1;
  } else {
    r.t1 = b.t1, r.face1 = b.face1;
  }
  return r;
}

/// The interval in which o + t d lies between lo and hi (either may be infinite).
Span slabSpan(double o, double d, double lo, double hi, int face_lo, int face_hi) {
  if (std::abs(d) < 1e-15) return (o >= lo && o <= hi) ? Span{} : kEmptySpan;
  const double ta = (lo - o) / d;
  const double tb = (hi - o) / d;
  return d > 0 ? Span{ta, tb, face_lo, face_hi} : Span{tb, ta, face_hi, face_lo};
}

Span quadraticSpan(double a, double b, double c, int face) {  // a t^2 + 2 b t + c <= 0
  const double disc = b * b - a * c;
  if (disc <= 0.0) return kEmptySpan;
  const double s = std::sqrt(disc);
  return {(-b - s) / a, (-b + s) / a, face, face};
}

Span sphereSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, int face) {
  return quadraticSpan(d.squaredNorm(), o.dot(d), o.squaredNorm() - r * r, face);
}

/// Infinite cylinder of radius r around the local z axis.
Span cylinderSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, int face) {
  const double a = d.x() * d.x() + d.y() * d.y();
  const double c = o.x() * o.x() + o.y() * o.y() - r * r;
  if (a < 1e-18) return c <= 0.0 ? Span{-kInf, kInf, face, face} : kEmptySpan;
  return quadraticSpan(a, o.x() * d.x() + o.y() * d.y(), c, face);
}

/// Where a ray that starts outside A first enters the solid A \ B: at A's entry unless that
/// lies inside B, in which case at B's exit (a surface of the cavity) if that is still in A.
bool firstEntryOfDifference(const Span& a, const Span& b, double& t, int& face) {
  if (a.empty() || a.t0 <= 0.0) return false;
  if (b.empty() || a.t0 < b.t0 || a.t0 > b.t1) {
    t = a.t0, face = a.face0;
    return face >= 0;
  }
  if (b.t1 < a.t1) {
    t = b.t1, face = b.face1;
    return face >= 0;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Solids in their local frames.

struct LocalHit {
  double t = kInf;
  int face = -1;
  Eigen::Vector3d normal;  ///< unit, local frame, pointing out of the material (towards the ray)
};

class Shape {
 public:
  virtual ~Shape() = default;
  /// The first surface point o + t d with t > 0, if any.
  virtual bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                         LocalHit& hit) const = 0;
  virtual Eigen::AlignedBox3d bounds() const = 0;
};

Eigen::Vector3d axisNormal(int face) {  // faces 0..5 = -x, +x, -y, +y, -z, +z
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[face / 2] = (face % 2) ? 1.0 : -1.0;
  return n;
}

Span boxSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& half) {
  Span s = slabSpan(o.x(), d.x(), -half.x(), half.x(), 0, 1);
  s = intersectSpans(s, slabSpan(o.y(), d.y(), -half.y(), half.y(), 2, 3));
  if (s.empty()) return s;
  return intersectSpans(s, slabSpan(o.z(), d.z(), -half.z(), half.z(), 4, 5));
}

/// A box centred on the origin. Faces 0..5 = -x, +x, -y, +y, -z, +z.
class BoxShape final : public Shape {
 public:
  explicit BoxShape(Eigen::Vector3d half) : half_(std::move(half)) {}
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override {
    const Span s = boxSpan(o, d, half_);
    if (s.empty() || s.t0 <= 0.0) return false;
    hit.t = s.t0, hit.face = s.face0, hit.normal = axisNormal(s.face0);
    return true;
  }
  Eigen::AlignedBox3d bounds() const override { return {-half_, half_}; }

 private:
  Eigen::Vector3d half_;
};

/// The inside of a box (the room): the ray leaves it through one face. Faces as BoxShape.
class RoomShape final : public Shape {
 public:
  explicit RoomShape(Eigen::Vector3d half) : half_(std::move(half)) {}
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override {
    const Span s = boxSpan(o, d, half_);
    if (s.empty() || s.t1 <= 0.0) return false;
    hit.t = s.t1, hit.face = s.face1, hit.normal = -axisNormal(s.face1);
    return true;
  }
  Eigen::AlignedBox3d bounds() const override { return {-half_, half_}; }

 private:
  Eigen::Vector3d half_;
};

/// A spherical-cap shell: the ball of radius `radius` below the rim plane z = rim_z (<= 0),
/// minus the concentric ball of radius radius - thickness. Origin at the sphere centre, z
/// towards the opening.
class BowlShape final : public Shape {
 public:
  enum Face { kOuter, kRim, kInner };
  BowlShape(double radius, double rim_z, double thickness)
      : radius_(radius), rim_z_(rim_z), inner_radius_(radius - thickness) {}
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override {
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
  Eigen::AlignedBox3d bounds() const override {
    const double rim = std::sqrt(radius_ * radius_ - rim_z_ * rim_z_);
    return {Eigen::Vector3d(-rim, -rim, -radius_), Eigen::Vector3d(rim, rim, rim_z_)};
  }

 private:
  double radius_;
  double rim_z_;
  double inner_radius_;
};

/// An open cylinder (cup): outer radius, height, wall and bottom thickness. Origin at the
/// centre of the bottom, z up.
class CupShape final : public Shape {
 public:
  enum Face { kOuter, kBottom, kRim, kInner, kInnerBottom };
  CupShape(double radius, double height, double wall, double bottom)
      : radius_(radius), height_(height), inner_radius_(radius - wall), bottom_(bottom) {}
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override {
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
        hit.normal = Eigen::Vector3d(p.x(), p.y(), 0.0) / radius_;
        break;
      case kBottom:
        hit.normal = -Eigen::Vector3d::UnitZ();
        break;
      case kInner:
        hit.normal = -Eigen::Vector3d(p.x(), p.y(), 0.0) / inner_radius_;
        break;
      default:
        hit.normal = Eigen::Vector3d::UnitZ();
        break;  // rim, inner bottom
    }
    return true;
  }
  Eigen::AlignedBox3d bounds() const override {
    return {Eigen::Vector3d(-radius_, -radius_, 0.0), Eigen::Vector3d(radius_, radius_, height_)};
  }

 private:
  double radius_;
  double height_;
  double inner_radius_;
  double bottom_;
};

/// A closed cylinder (tin). Origin at the centre of the bottom, z up.
class CylinderShape final : public Shape {
 public:
  enum Face { kSide, kBottom, kTop };
  CylinderShape(double radius, double height) : radius_(radius), height_(height) {}
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override {
    const Span s = intersectSpans(cylinderSpan(o, d, radius_, kSide),
                                  slabSpan(o.z(), d.z(), 0.0, height_, kBottom, kTop));
    if (s.empty() || s.t0 <= 0.0) return false;
    hit.t = s.t0, hit.face = s.face0;
    const Eigen::Vector3d p = o + hit.t * d;
    switch (hit.face) {
      case kSide:
        hit.normal = Eigen::Vector3d(p.x(), p.y(), 0.0) / radius_;
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
  Eigen::AlignedBox3d bounds() const override {
    return {Eigen::Vector3d(-radius_, -radius_, 0.0), Eigen::Vector3d(radius_, radius_, height_)};
  }

 private:
  double radius_;
  double height_;
};

class SphereShape final : public Shape {
 public:
  explicit SphereShape(double radius) : radius_(radius) {}
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, LocalHit& hit) const override {
    const Span s = sphereSpan(o, d, radius_, 0);
    if (s.empty() || s.t0 <= 0.0) return false;
    hit.t = s.t0, hit.face = 0, hit.normal = (o + s.t0 * d) / radius_;
    return true;
  }
  Eigen::AlignedBox3d bounds() const override {
    return {Eigen::Vector3d::Constant(-radius_), Eigen::Vector3d::Constant(radius_)};
  }

 private:
  double radius_;
};

// ---------------------------------------------------------------------------------------------
// The generated scene.

struct SurfaceDef {
  std::string name;
  SurfaceKind kind = SurfaceKind::kPlane;
  Eigen::Vector4d world_plane = Eigen::Vector4d::Zero();  ///< any orientation
  std::uint16_t object_id = 0;
  Eigen::Vector3f colour_bgr = Eigen::Vector3f::Zero();  ///< 0..255
};

struct ObjectDef {
  std::string kind;
  std::string name;
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();
  Eigen::AlignedBox3d local_box;  ///< tight bounds in the object frame
  // Bowls only: the object frame is the sphere centre with z towards the opening.
  bool is_bowl = false;
  bool upright = true;
  double rim_z = 0.0;
  double rim_radius = 0.0;
  double depth = 0.0;
  double thickness = 0.0;
};

struct Primitive {
  std::unique_ptr<const Shape> shape;
  Eigen::Isometry3d world_from_local = Eigen::Isometry3d::Identity();
  std::uint16_t object_id = 0;
  std::vector<std::uint16_t> surface_of_face;
};

/// Slow periodic camera sway: per axis (tx, ty, tz in m, rx, ry, rz in rad, camera frame)
/// amplitude * sin(2 pi f t + phase).
struct Sway {
  std::array<double, 6> amplitude{};
  std::array<double, 6> frequency_hz{};
  std::array<double, 6> phase{};

  Eigen::Isometry3d at(double seconds, double scale) const {
    std::array<double, 6> v{};
    for (std::size_t i = 0; i < 6; ++i)
      v[i] = scale * amplitude[i] *
             std::sin(2.0 * std::numbers::pi * frequency_hz[i] * seconds + phase[i]);
    Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
    offset.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    offset.linear() = (Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX()) *
                       Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()))
                          .toRotationMatrix();
    return offset;
  }
};

}  // namespace

class SceneModel {
 public:
  std::vector<SurfaceDef> surfaces;   ///< surface id = index + 1
  std::vector<ObjectDef> objects;     ///< object id = index + 1
  std::vector<Primitive> primitives;  ///< primitives[0] is the room
  Eigen::Isometry3d base_world_from_camera = Eigen::Isometry3d::Identity();
  Sway sway;
};

namespace {

Eigen::Vector4d worldPlane(const Eigen::Isometry3d& world_from_local,
                           const Eigen::Vector3d& n_local, const Eigen::Vector3d& point_local) {
  const Eigen::Vector3d n = world_from_local.linear() * n_local;
  const Eigen::Vector3d p = world_from_local * point_local;
  return {n.x(), n.y(), n.z(), -n.dot(p)};
}

Eigen::Isometry3d poseAt(const Eigen::Vector3d& position, double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = position;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

/// OpenCV camera axes (x right, y down, z forward) looking from `eye` at `target`, world z up.
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double roll) {
  const Eigen::Vector3d forward = (target - eye).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = right;
  pose.linear().col(1) = down;
  pose.linear().col(2) = forward;
  pose.linear() =
      pose.linear() * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = eye;
  return pose;
}

Eigen::Vector3f jitterColour(Rng& rng, Eigen::Vector3f bgr, double amount) {
  const float scale = static_cast<float>(rng.uniform(1.0 - amount, 1.0 + amount));
  return (bgr * scale).cwiseMin(255.0f);
}

/// A circle that must stay clear of others on the same support surface.
struct Footprint {
  Eigen::Vector2d center;
  double radius = 0.0;
};

/// Generates a plausible random layout from the seed. One object per call of add*(); the order
/// of random draws is part of the scene definition, so changing it changes every scene.
class LayoutBuilder {
 public:
  explicit LayoutBuilder(const SceneParams& params)
      : params_(params),
        rng_(mix64(params.seed ^ kLayoutStream)),
        model_(std::make_unique<SceneModel>()) {}

  std::unique_ptr<const SceneModel> build() {
    placeCameraAndTable();
    addRoom();
    addTable();
    const int boxes = rng_.uniformInt(params_.boxes_on_table_min, params_.boxes_on_table_max);
    for (int i = 0; i < boxes; ++i) addTableBox();
    if (rng_.chance(params_.floor_box_probability)) addFloorBox();
    const int bowls = rng_.uniformInt(params_.bowls_min, params_.bowls_max);
    for (int i = 0; i < bowls; ++i) addBowl();
    const int cups = rng_.uniformInt(params_.cups_min, params_.cups_max);
    for (int i = 0; i < cups; ++i) addCup();
    const int tins = rng_.uniformInt(params_.tins_min, params_.tins_max);
    for (int i = 0; i < tins; ++i) addTin();
    const int balls = rng_.uniformInt(params_.balls_min, params_.balls_max);
    for (int i = 0; i < balls; ++i) addBall();
    makeSway();
    return std::move(model_);
  }

 private:
  // --- camera and table -----------------------------------------------------------------------
  void placeCameraAndTable() {
    const double min_elevation = degToRad(params_.min_table_elevation_deg);
    for (int attempt = 0; attempt < 1000; ++attempt) {
      const double camera_height =
          rng_.uniform(params_.camera_height_min_m, params_.camera_height_max_m);
      table_height_ = rng_.uniform(0.62, 0.78);
      table_size_ = {rng_.uniform(0.8, 1.6), rng_.uniform(0.6, 1.0)};
      const double rise = camera_height - table_height_;
      if (rise <= 0.05) continue;
      const double max_distance =
          std::min(params_.table_distance_max_m, rise / std::sin(min_elevation));
      if (max_distance < params_.table_distance_min_m) continue;
      const double distance = rng_.uniform(params_.table_distance_min_m, max_distance);
      const double horizontal = std::sqrt(distance * distance - rise * rise);
      const double azimuth = degToRad(rng_.uniform(-10.0, 10.0));
      table_center_ = {horizontal * std::sin(azimuth), horizontal * std::cos(azimuth)};
      table_yaw_ = -azimuth + degToRad(rng_.uniform(-25.0, 25.0));
      // The robot stands beside the table, not over it.
      const Eigen::Vector2d camera_in_table =
          Eigen::Rotation2Dd(-table_yaw_) * (Eigen::Vector2d::Zero() - table_center_);
      const Eigen::Vector2d outside =
          (camera_in_table.cwiseAbs() - table_size_ / 2.0).cwiseMax(0.0);
      if (outside.norm() < 0.15) continue;
      camera_position_ = {0.0, 0.0, camera_height};
      const Eigen::Vector3d target(table_center_.x() + rng_.uniform(-0.1, 0.1),
                                   table_center_.y() + rng_.uniform(-0.1, 0.1), table_height_);
      model_->base_world_from_camera =
          lookAt(camera_position_, target, degToRad(rng_.uniform(-1.0, 1.0)));
      return;
    }
    throw std::invalid_argument(
        "SceneParams: no camera height / table distance satisfies min_table_elevation_deg");
  }

  void addRoom() {
    // Walls close around the table; a layout is redrawn until two or three walls are in view
    // (ignoring occlusion by the table), with the gaps allowed to grow on later tries.
    const double c = std::abs(std::cos(table_yaw_)), s = std::abs(std::sin(table_yaw_));
    const Eigen::Vector2d table_reach(c * table_size_.x() / 2 + s * table_size_.y() / 2,
                                      s * table_size_.x() / 2 + c * table_size_.y() / 2);
    Eigen::Vector3d half;
    Eigen::Isometry3d pose;
    for (int attempt = 0;; ++attempt) {
      const double spread = 1.0 + 0.1 * attempt;
      const double left =
          std::min(table_center_.x() - table_reach.x(), -0.3) - rng_.uniform(0.05, 0.9);
      const double right =
          std::max(table_center_.x() + table_reach.x(), 0.3) + rng_.uniform(0.05, 1.5);
      const double back = table_center_.y() + table_reach.y() + rng_.uniform(0.1, 0.9 * spread);
      const double front = -rng_.uniform(0.8, 1.5);
      const double ceiling = rng_.uniform(2.4, 2.8);
      room_min_ = {left, front};
      room_max_ = {right, back};
      half = Eigen::Vector3d(0.5 * (right - left), 0.5 * (back - front), 0.5 * ceiling);
      pose = poseAt({0.5 * (left + right), 0.5 * (front + back), 0.5 * ceiling}, 0.0);
      if (visibleWalls(RoomShape(half), pose) >= 2 || attempt >= 50) break;
    }

    const Eigen::Vector3f floor_colour(rng_.uniform(90, 150), rng_.uniform(110, 160),
                                       rng_.uniform(120, 170));
    const Eigen::Vector3f wall_colour(rng_.uniform(170, 230), rng_.uniform(180, 235),
                                      rng_.uniform(185, 240));
    // RoomShape faces: -x, +x, -y, +y, -z, +z.
    const std::array<const char*, 6> names = {"wall_left", "wall_right", "wall_front",
                                              "wall_back", "floor",      "ceiling"};
    std::vector<std::uint16_t> faces;
    for (int f = 0; f < 6; ++f) {
      const Eigen::Vector3d n = axisNormal(f);
      const Eigen::Vector3f colour = f == 4 ? floor_colour : jitterColour(rng_, wall_colour, 0.08);
      faces.push_back(addSurface(names[f], SurfaceKind::kPlane,
                                 worldPlane(pose, n, n.cwiseProduct(half)), 0, colour));
    }
    addPrimitive(std::make_unique<RoomShape>(half), pose, 0, std::move(faces));
  }

  /// How many of the left, right and back walls a coarse grid of camera rays sees in range.
  int visibleWalls(const RoomShape& room, const Eigen::Isometry3d& world_from_room) const {
    const CameraIntrinsics& k = params_.intrinsics;
    const Eigen::Isometry3d room_from_camera =
        world_from_room.inverse() * model_->base_world_from_camera;
    std::array<int, 6> rays_per_face{};
    constexpr int kGrid = 24;
    for (int gy = 0; gy < kGrid; ++gy)
      for (int gx = 0; gx < kGrid; ++gx) {
        const double u = (gx + 0.5) * k.width / kGrid, v = (gy + 0.5) * k.height / kGrid;
        LocalHit hit;
        if (room.intersect(room_from_camera.translation(), room_from_camera.linear() * k.ray(u, v),
                           hit) &&
            hit.t < params_.kinect.max_range_m - 0.1)
          ++rays_per_face[static_cast<std::size_t>(hit.face)];
      }
    constexpr int kMinRays = 4;  // ~1% of the image each
    return (rays_per_face[0] >= kMinRays) + (rays_per_face[1] >= kMinRays) +
           (rays_per_face[3] >= kMinRays);
  }

  void addTable() {
    const double top_thickness = rng_.uniform(0.025, 0.045);
    const double leg = rng_.uniform(0.04, 0.07);
    const double inset = rng_.uniform(0.03, 0.1);
    const Eigen::Vector3f wood(rng_.uniform(40, 90), rng_.uniform(70, 120), rng_.uniform(110, 170));

    ObjectDef table;
    table.kind = "table";
    table.name = "table";
    table.world_from_object = poseAt({table_center_.x(), table_center_.y(), 0.0}, table_yaw_);
    table.local_box = Eigen::AlignedBox3d(
        Eigen::Vector3d(-table_size_.x() / 2, -table_size_.y() / 2, 0.0),
        Eigen::Vector3d(table_size_.x() / 2, table_size_.y() / 2, table_height_));
    const std::uint16_t id = addObject(table);

    addBoxPrimitive(
        table.world_from_object * poseAt({0.0, 0.0, table_height_ - top_thickness / 2}, 0.0),
        {table_size_.x() / 2, table_size_.y() / 2, top_thickness / 2}, id,
        {"table_edge_left", "table_edge_right", "table_edge_front", "table_edge_back",
         "table_underside", "table_top"},
        wood);
    const double leg_height = table_height_ - top_thickness;
    const double lx = table_size_.x() / 2 - inset - leg / 2;
    const double ly = table_size_.y() / 2 - inset - leg / 2;
    const std::array<Eigen::Vector2d, 4> corners = {
        Eigen::Vector2d(-lx, -ly), Eigen::Vector2d(lx, -ly), Eigen::Vector2d(lx, ly),
        Eigen::Vector2d(-lx, ly)};
    for (int k = 0; k < 4; ++k) {
      const std::string prefix = "table_leg" + std::to_string(k + 1) + "_face_";
      addBoxPrimitive(
          table.world_from_object * poseAt({corners[k].x(), corners[k].y(), leg_height / 2}, 0.0),
          {leg / 2, leg / 2, leg_height / 2}, id,
          {prefix + "left", prefix + "right", prefix + "front", prefix + "back", prefix + "bottom",
           prefix + "top"},
          wood * 0.85f);
    }
  }

  // --- objects ----------------------------------------------------------------------------------
  Eigen::Vector3f objectColour() {
    static constexpr std::array<std::array<float, 3>, 8> kPalette = {{
        {60, 60, 200},
        {60, 170, 60},
        {200, 110, 40},
        {40, 180, 220},
        {170, 60, 160},
        {230, 230, 230},
        {90, 140, 200},
        {50, 50, 60},
    }};
    const auto& c = kPalette[static_cast<std::size_t>(
        rng_.uniformInt(0, static_cast<int>(kPalette.size()) - 1))];
    return jitterColour(rng_, Eigen::Vector3f(c[0], c[1], c[2]), 0.15);
  }

  void addTableBox() {
    const Eigen::Vector3d size(rng_.uniform(0.06, 0.32), rng_.uniform(0.06, 0.32),
                               rng_.uniform(0.05, 0.3));
    const auto spot = tableSpot(0.5 * std::hypot(size.x(), size.y()));
    if (!spot) return;
    addBox(*spot, size);
  }

  void addFloorBox() {
    const Eigen::Vector3d size(rng_.uniform(0.2, 0.45), rng_.uniform(0.2, 0.45),
                               rng_.uniform(0.15, 0.45));
    const auto spot = floorSpot(0.5 * std::hypot(size.x(), size.y()), size.z());
    if (!spot) return;
    addBox(*spot, size);
  }

  /// `support` is a pose on the supporting surface (z up) where the box's bottom centre goes.
  void addBox(const Eigen::Isometry3d& support, const Eigen::Vector3d& size) {
    const bool cardboard = rng_.chance(0.5);
    const Eigen::Vector3f colour =
        cardboard ? jitterColour(rng_, Eigen::Vector3f(70, 130, 175), 0.12) : objectColour();
    ObjectDef box;
    box.kind = "box";
    box.name = "box" + std::to_string(++box_count_);
    box.world_from_object = support * poseAt({0.0, 0.0, size.z() / 2}, 0.0);
    box.local_box = Eigen::AlignedBox3d(-size / 2, size / 2);
    const std::uint16_t id = addObject(box);
    const std::string prefix = box.name + "_face_";
    addBoxPrimitive(box.world_from_object, size / 2, id,
                    {prefix + "left", prefix + "right", prefix + "front", prefix + "back",
                     prefix + "bottom", prefix + "top"},
                    colour);
  }

  void addBowl() {
    const double rim_radius = rng_.uniform(0.06, 0.15);
    const double shallowness = rng_.uniform(0.0, 0.45);  // 0 = hemisphere
    const double radius = rim_radius / std::sqrt(1.0 - shallowness * shallowness);
    const double rim_z = -shallowness * radius;
    const double thickness = rng_.uniform(0.004, 0.01);
    const bool upright = !rng_.chance(params_.bowl_upside_down_probability);
    const auto spot = tableSpot(rim_radius);
    if (!spot) return;

    ObjectDef bowl;
    bowl.kind = "bowl";
    bowl.name = "bowl" + std::to_string(++bowl_count_);
    bowl.is_bowl = true;
    bowl.upright = upright;
    bowl.rim_z = rim_z;
    bowl.rim_radius = rim_radius;
    bowl.depth = radius + rim_z;
    bowl.thickness = thickness;
    // Upright it rests on the lowest point of its outer sphere, upside down on its rim.
    if (upright) {
      bowl.world_from_object = *spot * poseAt({0.0, 0.0, radius}, 0.0);
    } else {
      Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
      flip.translation() = Eigen::Vector3d(0.0, 0.0, -rim_z);
      flip.linear() =
          Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix();
      bowl.world_from_object = *spot * flip;
    }
    auto shape = std::make_unique<BowlShape>(radius, rim_z, thickness);
    bowl.local_box = shape->bounds();
    const std::uint16_t id = addObject(bowl);
    const Eigen::Vector3f colour = objectColour();
    std::vector<std::uint16_t> faces(3);
    faces[BowlShape::kOuter] =
        addSurface(bowl.name + "_outer", SurfaceKind::kCurved, Eigen::Vector4d::Zero(), id, colour);
    faces[BowlShape::kRim] =
        addSurface(bowl.name + "_rim", SurfaceKind::kPlane,
                   worldPlane(bowl.world_from_object, Eigen::Vector3d::UnitZ(), {0.0, 0.0, rim_z}),
                   id, colour * 1.05f);
    faces[BowlShape::kInner] = addSurface(bowl.name + "_inner", SurfaceKind::kCurved,
                                          Eigen::Vector4d::Zero(), id, colour * 0.9f);
    addPrimitive(std::move(shape), bowl.world_from_object, id, std::move(faces));
  }

  void addCup() {
    const double radius = rng_.uniform(0.035, 0.05);
    const double height = rng_.uniform(0.08, 0.12);
    const double wall = rng_.uniform(0.003, 0.005);
    const double bottom = rng_.uniform(0.005, 0.01);
    const auto spot = tableSpot(radius);
    if (!spot) return;
    ObjectDef cup;
    cup.kind = "cup";
    cup.name = "cup" + std::to_string(++cup_count_);
    cup.world_from_object = *spot;
    auto shape = std::make_unique<CupShape>(radius, height, wall, bottom);
    cup.local_box = shape->bounds();
    const std::uint16_t id = addObject(cup);
    const Eigen::Vector3f colour = objectColour();
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    std::vector<std::uint16_t> faces(5);
    faces[CupShape::kOuter] =
        addSurface(cup.name + "_outer", SurfaceKind::kCurved, Eigen::Vector4d::Zero(), id, colour);
    faces[CupShape::kBottom] =
        addSurface(cup.name + "_bottom", SurfaceKind::kPlane,
                   worldPlane(*spot, -up, Eigen::Vector3d::Zero()), id, colour);
    faces[CupShape::kRim] = addSurface(cup.name + "_rim", SurfaceKind::kPlane,
                                       worldPlane(*spot, up, height * up), id, colour * 1.05f);
    faces[CupShape::kInner] = addSurface(cup.name + "_inner", SurfaceKind::kCurved,
                                         Eigen::Vector4d::Zero(), id, colour * 0.9f);
    faces[CupShape::kInnerBottom] =
        addSurface(cup.name + "_inner_bottom", SurfaceKind::kPlane,
                   worldPlane(*spot, up, bottom * up), id, colour * 0.8f);
    addPrimitive(std::move(shape), cup.world_from_object, id, std::move(faces));
  }

  void addTin() {
    const double radius = rng_.uniform(0.03, 0.06);
    const double height = rng_.uniform(0.06, 0.2);
    const auto spot = tableSpot(radius);
    if (!spot) return;
    ObjectDef tin;
    tin.kind = "tin";
    tin.name = "tin" + std::to_string(++tin_count_);
    tin.world_from_object = *spot;
    auto shape = std::make_unique<CylinderShape>(radius, height);
    tin.local_box = shape->bounds();
    const std::uint16_t id = addObject(tin);
    const Eigen::Vector3f colour =
        rng_.chance(0.5) ? jitterColour(rng_, {175, 175, 180}, 0.1) : objectColour();
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    std::vector<std::uint16_t> faces(3);
    faces[CylinderShape::kSide] =
        addSurface(tin.name + "_side", SurfaceKind::kCurved, Eigen::Vector4d::Zero(), id, colour);
    faces[CylinderShape::kBottom] =
        addSurface(tin.name + "_bottom", SurfaceKind::kPlane,
                   worldPlane(*spot, -up, Eigen::Vector3d::Zero()), id, colour);
    faces[CylinderShape::kTop] = addSurface(tin.name + "_top", SurfaceKind::kPlane,
                                            worldPlane(*spot, up, height * up), id, colour * 1.1f);
    addPrimitive(std::move(shape), tin.world_from_object, id, std::move(faces));
  }

  void addBall() {
    const double radius = rng_.uniform(0.03, 0.11);
    const auto spot = tableSpot(radius);
    if (!spot) return;
    ObjectDef ball;
    ball.kind = "ball";
    ball.name = "ball" + std::to_string(++ball_count_);
    ball.world_from_object = *spot * poseAt({0.0, 0.0, radius}, 0.0);
    auto shape = std::make_unique<SphereShape>(radius);
    ball.local_box = shape->bounds();
    const std::uint16_t id = addObject(ball);
    addPrimitive(
        std::move(shape), ball.world_from_object, id,
        {addSurface(ball.name, SurfaceKind::kCurved, Eigen::Vector4d::Zero(), id, objectColour())});
  }

  // --- placement
  // ----------------------------------------------------------------------------------
  /// A free spot on the table top for a footprint of `radius`, as a pose on the top surface
  /// with random yaw; nullopt when none is found.
  std::optional<Eigen::Isometry3d> tableSpot(double radius) {
    const Eigen::Vector2d reach = table_size_ / 2.0 - Eigen::Vector2d::Constant(radius + 0.01);
    if (reach.minCoeff() < 0.0) return std::nullopt;
    for (int attempt = 0; attempt < 200; ++attempt) {
      const Eigen::Vector2d c(rng_.uniform(-reach.x(), reach.x()),
                              rng_.uniform(-reach.y(), reach.y()));
      if (!isFree(table_footprints_, c, radius)) continue;
      table_footprints_.push_back({c, radius});
      const Eigen::Isometry3d table_top =
          poseAt({table_center_.x(), table_center_.y(), table_height_}, table_yaw_);
      return table_top *
             poseAt({c.x(), c.y(), 0.0}, rng_.uniform(-std::numbers::pi, std::numbers::pi));
    }
    return std::nullopt;
  }

  /// A free floor spot beside or in front of the table, in the camera's view.
  std::optional<Eigen::Isometry3d> floorSpot(double radius, double height) {
    const Eigen::Isometry3d camera_from_world = model_->base_world_from_camera.inverse();
    const CameraIntrinsics& k = params_.intrinsics;
    for (int attempt = 0; attempt < 200; ++attempt) {
      Eigen::Vector2d local;  // table frame
      const double gap = rng_.uniform(0.05, 0.6);
      if (rng_.chance(0.7)) {
        local = {rng_.sign() * (table_size_.x() / 2 + radius + gap),
                 rng_.uniform(-0.5, 0.5) * table_size_.y()};
      } else {
        local = {rng_.uniform(-0.5, 0.5) * table_size_.x(), -(table_size_.y() / 2 + radius + gap)};
      }
      const Eigen::Vector2d c = table_center_ + Eigen::Rotation2Dd(table_yaw_) * local;
      if ((c - room_min_).minCoeff() < radius + 0.02 || (room_max_ - c).minCoeff() < radius + 0.02)
        continue;
      if ((c - camera_position_.head<2>()).norm() < radius + 0.45) continue;
      if (!isFree(floor_footprints_, c, radius)) continue;
      const Eigen::Vector3d top_cam = camera_from_world * Eigen::Vector3d(c.x(), c.y(), height);
      if (top_cam.z() < 0.6) continue;
      const Eigen::Vector2d px = k.project(top_cam);
      if (px.x() < 20 || px.y() < 20 || px.x() > k.width - 20 || px.y() > k.height - 20) continue;
      floor_footprints_.push_back({c, radius});
      return poseAt({c.x(), c.y(), 0.0}, rng_.uniform(-std::numbers::pi, std::numbers::pi));
    }
    return std::nullopt;
  }

  static bool isFree(const std::vector<Footprint>& taken, const Eigen::Vector2d& c, double radius) {
    constexpr double kGap = 0.01;
    return std::all_of(taken.begin(), taken.end(), [&](const Footprint& f) {
      return (f.center - c).norm() >= f.radius + radius + kGap;
    });
  }

  // --- bookkeeping
  // ----------------------------------------------------------------------------------
  std::uint16_t addSurface(std::string name, SurfaceKind kind, const Eigen::Vector4d& plane,
                           std::uint16_t object_id, const Eigen::Vector3f& colour) {
    model_->surfaces.push_back({std::move(name), kind, plane, object_id, colour.cwiseMin(255.0f)});
    return static_cast<std::uint16_t>(model_->surfaces.size());
  }

  std::uint16_t addObject(const ObjectDef& object) {
    model_->objects.push_back(object);
    return static_cast<std::uint16_t>(model_->objects.size());
  }

  void addPrimitive(std::unique_ptr<const Shape> shape, const Eigen::Isometry3d& pose,
                    std::uint16_t object_id, std::vector<std::uint16_t> faces) {
    model_->primitives.push_back({std::move(shape), pose, object_id, std::move(faces)});
  }

  /// A box whose six faces (-x, +x, -y, +y, -z, +z) are surfaces named `names`.
  void addBoxPrimitive(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half,
                       std::uint16_t object_id, const std::array<std::string, 6>& names,
                       const Eigen::Vector3f& colour) {
    std::vector<std::uint16_t> faces;
    for (int f = 0; f < 6; ++f) {
      const Eigen::Vector3d n = axisNormal(f);
      faces.push_back(addSurface(names[f], SurfaceKind::kPlane,
                                 worldPlane(pose, n, n.cwiseProduct(half)), object_id,
                                 jitterColour(rng_, colour, 0.06)));
    }
    addPrimitive(std::make_unique<BoxShape>(half), pose, object_id, std::move(faces));
  }

  void makeSway() {
    Sway& s = model_->sway;
    for (std::size_t i = 0; i < 6; ++i) {
      s.amplitude[i] = i < 3 ? rng_.uniform(0.01, 0.03) : degToRad(rng_.uniform(0.4, 1.0));
      s.frequency_hz[i] = 1.0 / rng_.uniform(3.0, 9.0);
      s.phase[i] = rng_.uniform(0.0, 2.0 * std::numbers::pi);
    }
  }

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
  int box_count_ = 0;
  int bowl_count_ = 0;
  int cup_count_ = 0;
  int tin_count_ = 0;
  int ball_count_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Rendering.

/// Nearest hit per pixel. Holds extra columns right of the image: occluders there can still
/// shadow image pixels from the projector, which sits to the right of the camera.
struct HitBuffer {
  int width = 0;  ///< including the extra columns
  int height = 0;
  std::vector<float> depth;  ///< ray parameter = z; +inf where nothing was hit
  std::vector<std::uint16_t> surface;
  std::vector<std::uint16_t> object;
  std::vector<Eigen::Vector3f> normal;  ///< camera frame, unit

  HitBuffer(int w, int h)
      : width(w),
        height(h),
        depth(static_cast<std::size_t>(w) * h, std::numeric_limits<float>::infinity()),
        surface(depth.size(), 0),
        object(depth.size(), 0),
        normal(depth.size(), Eigen::Vector3f::Zero()) {}
  std::size_t index(int u, int v) const { return static_cast<std::size_t>(v) * width + u; }
};

/// Casts the camera rays of one frame against every primitive.
class RayCaster {
 public:
  RayCaster(const CameraIntrinsics& k, const Eigen::Isometry3d& world_from_camera, HitBuffer& hits)
      : k_(k), world_from_camera_(world_from_camera), hits_(hits) {}

  void cast(const Primitive& primitive) {
    const Eigen::Isometry3d local_from_camera =
        primitive.world_from_local.inverse() * world_from_camera_;
    const cv::Rect rect = screenRect(primitive, local_from_camera.inverse());
    const Eigen::Matrix3d r = local_from_camera.linear();
    const Eigen::Vector3d origin = local_from_camera.translation();
    const Eigen::Vector3d du = r.col(0) / k_.fx;  // d(direction)/du
    const Shape& shape = *primitive.shape;
    LocalHit hit;
    for (int v = rect.y; v < rect.y + rect.height; ++v) {
      const Eigen::Vector3d row =
          r.col(1) * ((v - k_.cy) / k_.fy) + r.col(2) - r.col(0) * (k_.cx / k_.fx);
      for (int u = rect.x; u < rect.x + rect.width; ++u) {
        const Eigen::Vector3d direction = row + du * u;
        if (!shape.intersect(origin, direction, hit)) continue;
        const std::size_t i = hits_.index(u, v);
        if (hit.t >= hits_.depth[i]) continue;
        hits_.depth[i] = static_cast<float>(hit.t);
        hits_.surface[i] = primitive.surface_of_face[static_cast<std::size_t>(hit.face)];
        hits_.object[i] = primitive.object_id;
        hits_.normal[i] = (r.transpose() * hit.normal).cast<float>();
      }
    }
  }

 private:
  /// Pixels the primitive can cover: the bounds of its projected bounding box.
  cv::Rect screenRect(const Primitive& primitive,
                      const Eigen::Isometry3d& camera_from_local) const {
    const cv::Rect all(0, 0, hits_.width, hits_.height);
    const Eigen::AlignedBox3d box = primitive.shape->bounds();
    double u0 = kInf, v0 = kInf, u1 = -kInf, v1 = -kInf;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d p =
          camera_from_local * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
      if (p.z() < 1e-3) return all;  // straddles the camera plane: no cheap bound
      const Eigen::Vector2d px = k_.project(p);
      u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x());
      v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
    }
    const double clamp_lo = -1e6, clamp_hi = 1e6;  // keep the int conversion defined
    const int x0 = static_cast<int>(std::floor(std::clamp(u0, clamp_lo, clamp_hi))) - 1;
    const int y0 = static_cast<int>(std::floor(std::clamp(v0, clamp_lo, clamp_hi))) - 1;
    const int x1 = static_cast<int>(std::ceil(std::clamp(u1, clamp_lo, clamp_hi))) + 2;
    const int y1 = static_cast<int>(std::ceil(std::clamp(v1, clamp_lo, clamp_hi))) + 2;
    return cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1)) & all;
  }

  const CameraIntrinsics& k_;
  Eigen::Isometry3d world_from_camera_;
  HitBuffer& hits_;
};

/// Pixels whose surface point the IR projector (at +baseline along camera x) cannot see.
/// Camera and projector are rectified along x, so each image row is one epipolar plane for both
/// and a point at column u appears at projector column u - f*b/z. Scanning a row from the right,
/// a point is hidden from the projector exactly when some point to its right already occupies a
/// smaller projector column (the projector's view of the row folds over it).
std::vector<std::uint8_t> projectorShadows(const HitBuffer& hits, int image_width, double fx,
                                           double baseline) {
  std::vector<std::uint8_t> shadow(static_cast<std::size_t>(image_width) * hits.height, 0);
  const double fb = fx * baseline;
  for (int v = 0; v < hits.height; ++v) {
    double min_projector_u = kInf;
    for (int u = hits.width - 1; u >= 0; --u) {
      const double z = hits.depth[hits.index(u, v)];
      if (!std::isfinite(z)) continue;
      const double projector_u = u - fb / z;
      if (projector_u > min_projector_u + 1e-6) {
        if (u < image_width) shadow[static_cast<std::size_t>(v) * image_width + u] = 1;
      } else {
        min_projector_u = std::min(min_projector_u, projector_u);
      }
    }
  }
  return shadow;
}

/// Turns the ideal hits into what a Kinect v1 reports, plus colour and label images.
class SensorModel {
 public:
  SensorModel(const SceneParams& params, const SceneModel& model, std::uint64_t index)
      : params_(params), model_(model), noise_(mix64(mix64(params.seed ^ kFrameStream) + index)) {}

  void apply(const HitBuffer& hits, const Eigen::Isometry3d& world_from_camera, Frame& frame,
             TruthFrame& truth) {
    const CameraIntrinsics& k = params_.intrinsics;
    const KinectParams& kp = params_.kinect;
    const std::vector<std::uint8_t> shadow =
        kp.projector_shadows
            ? projectorShadows(hits, k.width, k.fx, kp.projector_baseline_m)
            : std::vector<std::uint8_t>(static_cast<std::size_t>(k.width) * k.height, 0);
    frame.depth = cv::Mat::zeros(k.height, k.width, CV_16UC1);
    truth.surface_labels = cv::Mat::zeros(k.height, k.width, CV_16UC1);
    truth.object_labels = cv::Mat::zeros(k.height, k.width, CV_16UC1);
    truth.ideal_depth = cv::Mat::zeros(k.height, k.width, CV_32FC1);
    if (params_.render_colour) frame.rgb = cv::Mat::zeros(k.height, k.width, CV_8UC3);

    const double cos_max_incidence = std::cos(degToRad(kp.max_incidence_deg));
    // Light from above and a little from the camera's side, fixed in the world.
    const Eigen::Vector3f light =
        (world_from_camera.linear().transpose() * Eigen::Vector3d(0.3, -0.5, 1.0).normalized())
            .cast<float>();

    for (int v = 0; v < k.height; ++v) {
      auto* depth_row = frame.depth.ptr<std::uint16_t>(v);
      auto* surface_row = truth.surface_labels.ptr<std::uint16_t>(v);
      auto* object_row = truth.object_labels.ptr<std::uint16_t>(v);
      auto* ideal_row = truth.ideal_depth.ptr<float>(v);
      auto* rgb_row = params_.render_colour ? frame.rgb.ptr<cv::Vec3b>(v) : nullptr;
      const double ray_y = (v - k.cy) / k.fy;
      for (int u = 0; u < k.width; ++u) {
        const std::size_t i = hits.index(u, v);
        const double z = hits.depth[i];
        if (!std::isfinite(z)) continue;
        const Eigen::Vector3f& n = hits.normal[i];
        const std::size_t pixel = static_cast<std::size_t>(v) * k.width + u;
        if (rgb_row) rgb_row[u] = shade(hits.surface[i], n, light, noise_.bits(pixel, kColourDraw));
        if (z < kp.min_range_m || z > kp.max_range_m) continue;
        ideal_row[u] = static_cast<float>(z);

        if (shadow[pixel]) continue;
        const Eigen::Vector3f ray =
            Eigen::Vector3f(static_cast<float>((u - k.cx) / k.fx), static_cast<float>(ray_y), 1.0f)
                .normalized();
        if (std::abs(n.dot(ray)) < cos_max_incidence) continue;
        if (noise_.uniform(pixel, kDropoutDraw) < kp.dropout_rate) continue;
        const double measured = measure(z, noise_.normal(pixel, kDisparityDraw));
        if (measured < kp.min_range_m || measured > kp.max_range_m) continue;
        depth_row[u] =
            static_cast<std::uint16_t>(measured * 1000.0 + 0.5);  // positive: round half up
        surface_row[u] = hits.surface[i];
        object_row[u] = hits.object[i];
      }
    }
  }

 private:
  /// z -> noisy, quantised disparity -> z; 0 when the disparity is not positive.
  double measure(double z, double standard_normal) const {
    const KinectParams& kp = params_.kinect;
    const double disparity = kp.focal_baseline_px_m / z + kp.disparity_noise_px * standard_normal;
    if (disparity <= 0.0) return 0.0;
    // Round half up by truncation (cheaper than std::round; the value is positive).
    const double quantised =
        static_cast<double>(static_cast<std::int64_t>(disparity / kp.disparity_step_px + 0.5)) *
        kp.disparity_step_px;
    return quantised > 0.0 ? kp.focal_baseline_px_m / quantised : 0.0;
  }

  cv::Vec3b shade(std::uint16_t surface, const Eigen::Vector3f& normal,
                  const Eigen::Vector3f& light, std::uint64_t bits) const {
    const Eigen::Vector3f& base = model_.surfaces[surface - 1].colour_bgr;
    const float lambert = std::max(0.0f, normal.dot(light));
    cv::Vec3b out;
    for (int c = 0; c < 3; ++c) {
      const float noise = static_cast<float>((bits >> (8 * c)) & 0x7) - 3.5f;  // +-3.5 levels
      out[c] = cv::saturate_cast<std::uint8_t>(base[c] * (0.55f + 0.45f * lambert) + noise);
    }
    return out;
  }

  static constexpr unsigned kDropoutDraw = 0;
  static constexpr unsigned kColourDraw = 1;
  static constexpr unsigned kDisparityDraw = 2;  // and up

  const SceneParams& params_;
  const SceneModel& model_;
  PixelNoise noise_;
};

/// Fills the per-surface and per-object records of a frame from its label images.
class TruthBuilder {
 public:
  TruthBuilder(const SceneModel& model, const Eigen::Isometry3d& world_from_camera,
               const CameraIntrinsics& intrinsics)
      : model_(model), world_from_camera_(world_from_camera), intrinsics_(intrinsics) {}

  void build(TruthFrame& truth) const {
    truth.world_from_camera = world_from_camera_;
    std::vector<std::size_t> surface_pixels(model_.surfaces.size() + 1, 0);
    std::vector<std::size_t> object_pixels(model_.objects.size() + 1, 0);
    std::vector<cv::Rect> object_boxes(model_.objects.size() + 1);
    for (int v = 0; v < truth.surface_labels.rows; ++v) {
      const auto* surface_row = truth.surface_labels.ptr<std::uint16_t>(v);
      const auto* object_row = truth.object_labels.ptr<std::uint16_t>(v);
      for (int u = 0; u < truth.surface_labels.cols; ++u) {
        ++surface_pixels[surface_row[u]];
        const std::uint16_t o = object_row[u];
        if (o == 0) continue;
        if (object_pixels[o]++ == 0) {
          object_boxes[o] = cv::Rect(u, v, 1, 1);
        } else {
          object_boxes[o] |= cv::Rect(u, v, 1, 1);
        }
      }
    }

    truth.surfaces.clear();
    for (std::size_t s = 0; s < model_.surfaces.size(); ++s) {
      const SurfaceDef& def = model_.surfaces[s];
      TruthSurface out;
      out.id = static_cast<std::uint16_t>(s + 1);
      out.name = def.name;
      out.kind = def.kind;
      out.object_id = def.object_id;
      out.pixel_count = surface_pixels[s + 1];
      if (def.kind == SurfaceKind::kPlane) out.plane = cameraPlane(def.world_plane);
      truth.surfaces.push_back(std::move(out));
    }

    truth.objects.clear();
    for (std::size_t o = 0; o < model_.objects.size(); ++o) {
      TruthObject out = objectTruth(model_.objects[o]);
      out.id = static_cast<std::uint16_t>(o + 1);
      out.pixel_count = object_pixels[o + 1];
      out.image_box = object_boxes[o + 1];
      if (model_.objects[o].is_bowl && out.pixel_count > 0) {
        const double area = bowlSilhouetteArea(out);
        out.visible_fraction = area > 0 ? static_cast<double>(out.pixel_count) / area : 0.0;
      }
      truth.objects.push_back(std::move(out));
    }
  }

 private:
  /// The world plane in camera coordinates, oriented so the camera is on its positive side.
  Eigen::Vector4d cameraPlane(const Eigen::Vector4d& world_plane) const {
    const Eigen::Vector3d n_world = world_plane.head<3>();
    const double scale = 1.0 / n_world.norm();
    const Eigen::Vector3d n = world_from_camera_.linear().transpose() * n_world * scale;
    const double d = (n_world.dot(world_from_camera_.translation()) + world_plane.w()) * scale;
    const double sign = d < 0.0 ? -1.0 : 1.0;
    return {sign * n.x(), sign * n.y(), sign * n.z(), sign * d};
  }

  TruthObject objectTruth(const ObjectDef& def) const {
    const Eigen::Isometry3d camera_from_object =
        world_from_camera_.inverse() * def.world_from_object;
    TruthObject out;
    out.kind = def.kind;
    out.name = def.name;
    out.center = camera_from_object * def.local_box.center();
    out.size = def.local_box.sizes();
    out.rotation = camera_from_object.linear();
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d signs((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
      out.corners[static_cast<std::size_t>(i)] =
          out.center + out.rotation * signs.cwiseProduct(out.size / 2.0);
    }
    if (!def.is_bowl) return out;
    out.upright = def.upright;
    out.rim_center = camera_from_object * Eigen::Vector3d(0.0, 0.0, def.rim_z);
    out.axis = out.rotation.col(2);
    out.rim_radius_m = def.rim_radius;
    out.depth_m = def.depth;
    out.shell_thickness_m = def.thickness;
    const Eigen::Vector3d rim_world = def.world_from_object * Eigen::Vector3d(0.0, 0.0, def.rim_z);
    const Eigen::Vector3d to_camera = (world_from_camera_.translation() - rim_world).normalized();
    out.view_elevation_deg = radToDeg(std::asin(std::clamp(to_camera.z(), -1.0, 1.0)));
    out.view_class = bowlViewClass(out.view_elevation_deg);
    return out;
  }

  /// Area (pixels) of the projected outer shell of a bowl (TruthObject in camera coordinates):
  /// the convex hull of points sampled densely on the spherical cap, which projects to a convex
  /// outline. 0 when part of the bowl lies behind the camera plane.
  double bowlSilhouetteArea(const TruthObject& bowl) const {
    const double r = bowl.rim_radius_m, h = std::max(bowl.depth_m, 1e-4);
    const double sphere_r = (r * r + h * h) / (2.0 * h);
    const Eigen::Vector3d axis = bowl.axis.normalized();
    const Eigen::Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
    const Eigen::Vector3d centre = bowl.rim_center + axis * (sphere_r - h);
    const double polar_max = std::acos(std::clamp(1.0 - h / sphere_r, -1.0, 1.0));  // the rim
    constexpr int kPolar = 24, kAzimuth = 96;
    std::array<Eigen::Vector3d, kAzimuth> around;  // unit directions in the rim plane
    for (int j = 0; j < kAzimuth; ++j) {
      const double azimuth = 2.0 * std::numbers::pi * j / kAzimuth;
      around[static_cast<std::size_t>(j)] = std::cos(azimuth) * e1 + std::sin(azimuth) * e2;
    }
    std::vector<cv::Point2f> outline;
    outline.reserve((kPolar + 1) * kAzimuth);
    for (int i = 0; i <= kPolar; ++i) {
      const double polar = polar_max * i / kPolar;
      const double sin_polar = std::sin(polar), cos_polar = std::cos(polar);
      for (const Eigen::Vector3d& dir : around) {
        const Eigen::Vector3d p = centre + sphere_r * (sin_polar * dir - cos_polar * axis);
        if (p.z() < 0.01) return 0.0;
        const Eigen::Vector2d px = intrinsics_.project(p);
        outline.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
      }
    }
    std::vector<cv::Point2f> hull;
    cv::convexHull(outline, hull);
    return cv::contourArea(hull);
  }

  const SceneModel& model_;
  Eigen::Isometry3d world_from_camera_;
  const CameraIntrinsics& intrinsics_;
};

void validate(const SceneParams& p) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SceneParams: ") + what);
  };
  const CameraIntrinsics& k = p.intrinsics;
  require(k.width > 0 && k.height > 0 && k.fx > 0 && k.fy > 0, "intrinsics must be positive");
  require(p.frame_rate_hz > 0, "frame_rate_hz must be positive");
  require(p.camera_motion >= 0, "camera_motion must not be negative");
  require(p.camera_height_min_m <= p.camera_height_max_m, "camera height range is empty");
  require(p.table_distance_min_m > 0 && p.table_distance_min_m <= p.table_distance_max_m,
          "table distance range is empty");
  require(p.min_table_elevation_deg > 0 && p.min_table_elevation_deg < 90,
          "min_table_elevation_deg out of (0, 90)");
  require(p.boxes_on_table_min >= 0 && p.boxes_on_table_min <= p.boxes_on_table_max,
          "box count range");
  require(p.bowls_min >= 0 && p.bowls_min <= p.bowls_max, "bowl count range");
  require(p.cups_min >= 0 && p.cups_min <= p.cups_max, "cup count range");
  require(p.tins_min >= 0 && p.tins_min <= p.tins_max, "tin count range");
  require(p.balls_min >= 0 && p.balls_min <= p.balls_max, "ball count range");
  const KinectParams& kp = p.kinect;
  require(kp.focal_baseline_px_m > 0 && kp.disparity_step_px > 0,
          "disparity model must be positive");
  require(kp.disparity_noise_px >= 0 && kp.dropout_rate >= 0 && kp.dropout_rate <= 1,
          "noise params");
  require(kp.min_range_m > 0 && kp.min_range_m < kp.max_range_m && kp.max_range_m < 65.0,
          "range limits");
  require(kp.projector_baseline_m >= 0, "projector_baseline_m must not be negative");
}

}  // namespace

std::string bowlViewClass(double elevation_deg) {
  if (elevation_deg > 60.0) return "top";
  if (elevation_deg >= 20.0) return "middle";
  return "side";
}

SyntheticScene::SyntheticScene(SceneParams params) : params_(std::move(params)) {
  validate(params_);
  model_ = LayoutBuilder(params_).build();
}

SyntheticScene::~SyntheticScene() = default;
SyntheticScene::SyntheticScene(SyntheticScene&&) noexcept = default;
SyntheticScene& SyntheticScene::operator=(SyntheticScene&&) noexcept = default;

Eigen::Isometry3d SyntheticScene::worldFromCamera(std::uint64_t index) const {
  const double seconds = static_cast<double>(index) / params_.frame_rate_hz;
  return model_->base_world_from_camera * model_->sway.at(seconds, params_.camera_motion);
}

RenderedFrame SyntheticScene::render(std::uint64_t index, TimestampNs timestamp_ns) const {
  const CameraIntrinsics& k = params_.intrinsics;
  const Eigen::Isometry3d world_from_camera = worldFromCamera(index);

  // Occluders up to this far right of the image can shadow image pixels (nearer ones are
  // below the sensor's minimum range and ignored).
  const int extra_columns =
      params_.kinect.projector_shadows
          ? static_cast<int>(std::ceil(k.fx * params_.kinect.projector_baseline_m /
                                       params_.kinect.min_range_m)) +
                2
          : 0;
  HitBuffer hits(k.width + extra_columns, k.height);
  RayCaster caster(k, world_from_camera, hits);
  for (const Primitive& primitive : model_->primitives) caster.cast(primitive);

  RenderedFrame out;
  out.frame.intrinsics = k;
  out.frame.timestamp_ns = timestamp_ns;
  out.frame.sequence = index;
  SensorModel(params_, *model_, index).apply(hits, world_from_camera, out.frame, out.truth);
  TruthBuilder(*model_, world_from_camera, k).build(out.truth);
  return out;
}

}  // namespace shapesense::synthetic
