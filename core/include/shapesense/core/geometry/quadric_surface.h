#pragma once
// Whether points lie on one quadric surface: a sphere, a cylinder, a cone, an ellipsoid, a
// paraboloid, or a pair of planes, at any extent. A height-field quadric (height_fit.h) fits only
// a cap of such a surface: over a bowl's whole outside or a bin seen across half its girth the
// surface turns parallel to any one direction, and the heights stop being a function. The
// implicit form f(x) = x'Ax + b'x + c = 0 has no such direction.

#include <initializer_list>
#include <span>

#include <Eigen/Core>

namespace shapesense {

/// The fit of an implicit quadric to points, by algebraic least squares (the coefficients of
/// unit norm that minimise the sum of f(x)^2, on the points centred and scaled to unit spread),
/// judged by the points' Sampson distances |f(x)| / |grad f(x)|, a first-order geometric
/// distance in metres.
struct QuadricSurfaceFit {
  int count = 0;       ///< points used
  double rms_m = 0.0;  ///< RMS Sampson distance of those points
  /// Enough points to pin its ten coefficients down: twice as many.
  bool reliable() const { return count >= 20; }
};

/// Fits one quadric to the union of `point_sets`, using at most `max_points` of them, evenly
/// strided over the union (the fit costs that many points whatever the sets hold).
QuadricSurfaceFit fitQuadricSurface(
    std::initializer_list<std::span<const Eigen::Vector3d>> point_sets, int max_points = 400);

}  // namespace shapesense
