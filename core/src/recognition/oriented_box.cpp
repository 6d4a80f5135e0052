#include "shapesense/core/recognition/oriented_box.h"

#include <limits>

#include <Eigen/Eigenvalues>

namespace shapesense {

OrientedBox principalBox(const std::vector<Eigen::Vector3f>& points) {
  OrientedBox box;
  if (points.empty()) return box;
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<float>(points.size());
  Eigen::Matrix3f covariance = Eigen::Matrix3f::Zero();
  for (const auto& p : points) covariance += (p - mean) * (p - mean).transpose();
  Eigen::Matrix3f axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f>(covariance).eigenvectors();
  if (axes.determinant() < 0.0f) axes.col(0) = -axes.col(0);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : points) {
    const Eigen::Vector3f local = axes.transpose() * (p - mean);
    lo = lo.cwiseMin(local);
    hi = hi.cwiseMax(local);
  }
  box.axes = axes;
  box.size = hi - lo;
  box.centre = mean + axes * (0.5f * (lo + hi));
  return box;
}

}  // namespace shapesense
