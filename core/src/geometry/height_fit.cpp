#include "shapesense/core/geometry/height_fit.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace shapesense {
namespace {

// The least-squares solution over the system's last `dims` unknowns (6: the quadric, 3: the
// plane) and its residual sum of squares.
struct LeastSquares {
  Eigen::VectorXd solution;
  double residual = 0.0;
};

LeastSquares solveLast(const HeightSums& s, int dims) {
  const Eigen::Matrix<double, 6, 6> m = s.normalMatrix();
  const Eigen::MatrixXd sub = m.bottomRightCorner(dims, dims);
  const Eigen::VectorXd rhs = s.rhs().tail(dims);
  LeastSquares fit;
  fit.solution = sub.ldlt().solve(rhs);
  fit.residual = std::max(0.0, s.sumOfSquaredHeights() - fit.solution.dot(rhs));
  return fit;
}

double largestCurvature(const Eigen::VectorXd& q) {
  Eigen::Matrix2d hessian;
  hessian << 2.0 * q[0], q[1], q[1], 2.0 * q[2];
  const Eigen::Vector2d k = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(hessian).eigenvalues();
  return std::max(std::fabs(k[0]), std::fabs(k[1]));
}

}  // namespace

HeightSums::HeightSums(const Eigen::Vector3d& normal)
    : normal_(normal), e1_(normal.unitOrthogonal()), e2_(normal.cross(e1_)) {}

Eigen::Matrix<double, 6, 6> HeightSums::normalMatrix() const {
  Eigen::Matrix<double, 6, 6> m;
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) m(i, j) = m(j, i) = products_[k++];
  return m;
}

Eigen::Matrix<double, 6, 1> HeightSums::rhs() const {
  return Eigen::Map<const Eigen::Matrix<double, 6, 1>>(rhs_.data());
}

double HeightFit::planeRms() const { return std::sqrt(plane_residual / std::max(count, 1)); }

double HeightFit::quadricRms() const { return std::sqrt(quadric_residual / std::max(count, 1)); }

double HeightFit::planeToQuadricRms() const {
  return std::sqrt(plane_residual / std::max(quadric_residual, 1e-18));
}

HeightFit fitHeights(const HeightSums& sums) {
  HeightFit fit;
  if (sums.count() < 6) return fit;
  fit.count = sums.count();
  const LeastSquares plane = solveLast(sums, 3), quadric = solveLast(sums, 6);
  fit.plane_residual = plane.residual;
  fit.quadric_residual = quadric.residual;
  fit.curvature = largestCurvature(quadric.solution);
  return fit;
}

}  // namespace shapesense
