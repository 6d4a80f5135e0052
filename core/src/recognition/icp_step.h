#pragma once
// The solve of one linearised ICP step (object_matching.cpp's pointToPlaneIcp): the motion x =
// (turn, move) that minimises the summed squared residuals whose normal equations are A x = b,
// either free or turning only about one axis.

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace shapesense::detail {

using IcpNormalMatrix = Eigen::Matrix<double, 6, 6>;
using IcpStep = Eigen::Matrix<double, 6, 1>;  ///< small turn (axis times angle), then move

/// The least-squares step among those that turn only about `axis` (unit, camera frame) and
/// move freely: the normal equations reduced to the four-dimensional subspace (turn about the
/// axis, move) and solved there. A pose standing on a known support keeps it.
inline IcpStep uprightStep(const IcpNormalMatrix& normal_matrix, const IcpStep& rhs,
                           const Eigen::Vector3d& axis) {
  Eigen::Matrix<double, 6, 4> basis = Eigen::Matrix<double, 6, 4>::Zero();
  basis.block<3, 1>(0, 0) = axis.normalized();
  basis.block<3, 3>(3, 1) = Eigen::Matrix3d::Identity();
  const Eigen::Matrix4d reduced = basis.transpose() * normal_matrix * basis;
  return basis * reduced.ldlt().solve(basis.transpose() * rhs);
}

}  // namespace shapesense::detail
