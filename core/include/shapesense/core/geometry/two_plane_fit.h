#pragma once
// Whether points lie on two planes: the two faces of a box corner, a table leg or a shelf board
// seen across their crease. A quadric (height_fit.h, quadric_surface.h) fits a crease too, bent
// to follow it, so a test for curvature alone takes two flat faces for a curved surface; two
// planes fit a crease better than any smooth quadric does, and a curved surface worse.

#include <cstddef>
#include <optional>
#include <span>

#include <Eigen/Core>

#include "shapesense/core/geometry/plane_fitting.h"

namespace shapesense {

/// Two planes fitted to points, each point to the nearer.
struct TwoPlanes {
  PlaneFit a, b;
  double residual = -1.0;  ///< sum of squared distances to the nearer plane; < 0: no fit

  /// Whether x lies nearer b than a (a point as far from both belongs to a).
  bool nearerB(const Eigen::Vector3d& x) const { return b.distance(x) < a.distance(x); }
};

/// Two planes fitted to at most kMaxFitPoints of a point set, evenly spread (enough for two
/// faces' planes, and the cost stays that of a few hundred points however large the set).
struct TwoPlaneFit {
  static constexpr std::size_t kMaxFitPoints = 150;
  TwoPlanes planes;
  std::size_t stride = 1;  ///< every stride-th point was fitted
  std::size_t fitted = 0;  ///< that many
  double rms() const;
  /// The stride of a fit to `count` points.
  static std::size_t strideFor(std::size_t count) {
    return (count + kMaxFitPoints - 1) / kMaxFitPoints;
  }
  /// Whether a fit to `count` points can pass facesHoldAtLeast(points): both faces together
  /// hold at most count + stride - 1 of them.
  static bool mayHoldFacesOf(std::size_t count, double points) {
    return static_cast<double>(count + strideFor(count) - 1) >= 2.0 * points;
  }
  /// Whether each face holds at least `points` of all the points (its count times the stride).
  bool facesHoldAtLeast(double points) const {
    const double fitted_points = points / static_cast<double>(stride);
    return planes.a.count >= fitted_points && planes.b.count >= fitted_points;
  }
};

/// The better of two fits by alternating assignment and refit, each from a split of the points
/// across one in-plane axis of their scatter through `centroid` (their mean). The planes'
/// counts are of the fitted points (every stride-th). None without points, or when a side gets
/// too few points for a plane.
std::optional<TwoPlaneFit> bestTwoPlanes(std::span<const Eigen::Vector3d> points,
                                         const Eigen::Vector3d& centroid);

}  // namespace shapesense
