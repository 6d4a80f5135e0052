#include "shapesense/core/geometry/quadric_surface.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/Eigenvalues>

namespace shapesense {
namespace {

using Monomials = Eigen::Matrix<double, 10, 1>;

// The quadric's ten monomials at x: x^2, y^2, z^2, xy, xz, yz, x, y, z, 1.
Monomials monomials(const Eigen::Vector3d& x) {
  Monomials m;
  m << x.x() * x.x(), x.y() * x.y(), x.z() * x.z(), x.x() * x.y(), x.x() * x.z(), x.y() * x.z(),
      x.x(), x.y(), x.z(), 1.0;
  return m;
}

// The gradient of f(x) = c . monomials(x).
Eigen::Vector3d gradient(const Monomials& c, const Eigen::Vector3d& x) {
  return {2.0 * c[0] * x.x() + c[3] * x.y() + c[4] * x.z() + c[6],
          2.0 * c[1] * x.y() + c[3] * x.x() + c[5] * x.z() + c[7],
          2.0 * c[2] * x.z() + c[4] * x.x() + c[5] * x.y() + c[8]};
}

}  // namespace

QuadricSurfaceFit fitQuadricSurface(
    std::initializer_list<std::span<const Eigen::Vector3d>> point_sets, int max_points) {
  std::size_t total = 0;
  for (const auto& set : point_sets) total += set.size();
  QuadricSurfaceFit fit;
  if (total == 0 || max_points <= 0) return fit;
  const std::size_t stride =
      (total + static_cast<std::size_t>(max_points) - 1) / static_cast<std::size_t>(max_points);
  // Calls f on every stride-th point of the union, in order.
  const auto for_each_used = [&](auto&& f) {
    std::size_t index = 0;
    for (const auto& set : point_sets)
      for (const Eigen::Vector3d& x : set)
        if (index++ % stride == 0) f(x);
  };
  // Centred and scaled to unit RMS spread: the monomials of points metres away and centimetres
  // apart would differ by orders of magnitude.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  int count = 0;
  for_each_used([&](const Eigen::Vector3d& x) {
    mean += x;
    ++count;
  });
  mean /= count;
  double spread = 0.0;
  for_each_used([&](const Eigen::Vector3d& x) { spread += (x - mean).squaredNorm(); });
  const double scale = std::sqrt(spread / count);
  // Points within a nanometre of one another are one point (and a spread that is not finite,
  // no points): no surface.
  constexpr double kMinSpreadM = 1e-9;
  if (!(scale > kMinSpreadM)) return fit;
  fit.count = count;
  if (!fit.reliable()) return fit;
  // The monomials of the used points, one row each; their scatter in one product.
  Eigen::Matrix<double, Eigen::Dynamic, 10> rows(count, 10);
  std::vector<Eigen::Vector3d> scaled;
  scaled.reserve(static_cast<std::size_t>(count));
  for_each_used([&](const Eigen::Vector3d& x) {
    scaled.push_back((x - mean) / scale);
    rows.row(static_cast<Eigen::Index>(scaled.size()) - 1) = monomials(scaled.back()).transpose();
  });
  const Eigen::Matrix<double, 10, 10> scatter = rows.transpose() * rows;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 10, 10>> solver(scatter);
  const Monomials c = solver.eigenvectors().col(0);  // eigenvalues ascending
  const Eigen::VectorXd f = rows * c;
  double sum = 0.0;
  int used = 0;
  for (std::size_t i = 0; i < scaled.size(); ++i) {
    const double g2 = gradient(c, scaled[i]).squaredNorm();
    if (!(g2 > 1e-12)) continue;  // at a singular point (a cone's apex) the distance is undefined
    sum += f[static_cast<Eigen::Index>(i)] * f[static_cast<Eigen::Index>(i)] / g2;
    ++used;
  }
  fit.count = used;
  fit.rms_m = used ? std::sqrt(sum / used) * scale : 0.0;
  return fit;
}

}  // namespace shapesense
