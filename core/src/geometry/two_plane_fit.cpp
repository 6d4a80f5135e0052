#include "shapesense/core/geometry/two_plane_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Eigenvalues>

namespace shapesense {
namespace {

// Two planes fitted to points by alternating assignment and refit, from a split of the points
// across `axis` through their centroid.
TwoPlanes fitTwoPlanes(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centroid,
                       const Eigen::Vector3d& axis) {
  constexpr int kIterations = 3;
  std::vector<std::uint8_t> on_b(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) on_b[i] = (points[i] - centroid).dot(axis) > 0;
  TwoPlanes two;
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    PlaneMoments moments_a, moments_b;
    for (std::size_t i = 0; i < points.size(); ++i)
      (on_b[i] ? moments_b : moments_a).add(points[i]);
    two.a = moments_a.fit();
    two.b = moments_b.fit();
    if (!two.a.valid || !two.b.valid) return TwoPlanes{};
    two.residual = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double da = two.a.normal.dot(points[i]) + two.a.d;
      const double db = two.b.normal.dot(points[i]) + two.b.d;
      on_b[i] = std::abs(db) < std::abs(da);
      two.residual += std::min(da * da, db * db);
    }
  }
  return two;
}

}  // namespace

double TwoPlaneFit::rms() const { return std::sqrt(planes.residual / static_cast<double>(fitted)); }

std::optional<TwoPlaneFit> bestTwoPlanes(std::span<const Eigen::Vector3d> points,
                                         const Eigen::Vector3d& centroid) {
  if (points.empty()) return std::nullopt;
  TwoPlaneFit two;
  two.stride = TwoPlaneFit::strideFor(points.size());
  std::vector<Eigen::Vector3d> fit_points;
  fit_points.reserve(points.size() / two.stride + 1);
  for (std::size_t i = 0; i < points.size(); i += two.stride) fit_points.push_back(points[i]);
  two.fitted = fit_points.size();
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& x : fit_points)
    scatter += (x - centroid) * (x - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> axes(scatter);  // ascending: normal first
  for (const int axis : {1, 2}) {
    const TwoPlanes planes = fitTwoPlanes(fit_points, centroid, axes.eigenvectors().col(axis));
    if (planes.residual >= 0.0 &&
        (two.planes.residual < 0.0 || planes.residual < two.planes.residual))
      two.planes = planes;
  }
  if (two.planes.residual < 0.0) return std::nullopt;
  return two;
}

}  // namespace shapesense
