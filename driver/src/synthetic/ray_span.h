#pragma once
// Ray intervals. All solids are convex pieces or differences of two convex pieces (a bowl is a
// sphere cut by a plane minus a smaller sphere), so every ray/solid query reduces to
// intersecting parameter intervals along the ray o + t d. A convex solid occupies one interval
// [t0, t1] of a ray; face0/face1 name the faces through which the ray enters and leaves.
//
// Inline: these run for every pixel a solid may cover.

#include <cmath>
#include <limits>

#include <Eigen/Core>

namespace shapesense::synthetic::detail {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Span {
  double t0 = -kInf;
  double t1 = kInf;
  int face0 = -1;
  int face1 = -1;
  bool empty() const { return !(t0 < t1); }
};
constexpr Span kEmptySpan{kInf, -kInf, -1, -1};

inline Span intersectSpans(const Span& a, const Span& b) {
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
inline Span slabSpan(double o, double d, double lo, double hi, int face_lo, int face_hi) {
  if (std::abs(d) < 1e-15) return (o >= lo && o <= hi) ? Span{} : kEmptySpan;
  const double ta = (lo - o) / d;
  const double tb = (hi - o) / d;
  return d > 0 ? Span{ta, tb, face_lo, face_hi} : Span{tb, ta, face_hi, face_lo};
}

inline Span quadraticSpan(double a, double b, double c, int face) {  // a t^2 + 2 b t + c <= 0
  const double disc = b * b - a * c;
  if (disc <= 0.0) return kEmptySpan;
  const double s = std::sqrt(disc);
  return {(-b - s) / a, (-b + s) / a, face, face};
}

inline Span sphereSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, int face) {
  return quadraticSpan(d.squaredNorm(), o.dot(d), o.squaredNorm() - r * r, face);
}

/// Infinite cylinder of radius r around the local z axis.
inline Span cylinderSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, int face) {
  const double a = d.x() * d.x() + d.y() * d.y();
  const double c = o.x() * o.x() + o.y() * o.y() - r * r;
  if (a < 1e-18) return c <= 0.0 ? Span{-kInf, kInf, face, face} : kEmptySpan;
  return quadraticSpan(a, o.x() * d.x() + o.y() * d.y(), c, face);
}

/// Axis-aligned box centred on the origin; faces 0..5 = -x, +x, -y, +y, -z, +z.
inline Span boxSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                    const Eigen::Vector3d& half) {
  Span s = slabSpan(o.x(), d.x(), -half.x(), half.x(), 0, 1);
  s = intersectSpans(s, slabSpan(o.y(), d.y(), -half.y(), half.y(), 2, 3));
  if (s.empty()) return s;
  return intersectSpans(s, slabSpan(o.z(), d.z(), -half.z(), half.z(), 4, 5));
}

/// The outward normal of boxSpan's face 0..5 (-x, +x, -y, +y, -z, +z).
inline Eigen::Vector3d axisNormal(int face) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[face / 2] = (face % 2) ? 1.0 : -1.0;
  return n;
}

/// Where a ray that starts outside A first enters the solid A \ B: at A's entry unless that
/// lies inside B, in which case at B's exit (a surface of the cavity) if that is still in A.
inline bool firstEntryOfDifference(const Span& a, const Span& b, double& t, int& face) {
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

}  // namespace shapesense::synthetic::detail
