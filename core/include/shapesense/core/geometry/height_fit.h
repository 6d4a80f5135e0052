#pragma once
// Whether a surface patch bends: least-squares fits of a plane and of a quadric to the heights of
// its points above a reference plane, h = q0 a^2 + q1 a b + q2 b^2 + q3 a + q4 b + q5 in the
// plane's own coordinates (a, b). The one curvature test of core/: the plane detector's checks
// that a region lies on a curved surface, and the segmentation's joining of curved objects.

#include <array>

#include <Eigen/Core>

namespace shapesense {

/// The least-squares sums of a point set's heights along one direction.
class HeightSums {
 public:
  /// Heights along `normal` (unit); in-plane coordinates along two fixed directions
  /// orthogonal to it. Sums are taken relative to the first point added, so that points at
  /// metres of range keep their precision.
  explicit HeightSums(const Eigen::Vector3d& normal = Eigen::Vector3d::UnitZ());

  void add(const Eigen::Vector3d& x) {
    if (count_ == 0) reference_ = x;
    const Eigen::Vector3d p = x - reference_;
    const double a = p.dot(e1_), b = p.dot(e2_), h = p.dot(normal_);
    const double f[6] = {a * a, a * b, b * b, a, b, 1.0};
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) products_[k++] += f[i] * f[j];
      rhs_[i] += h * f[i];
    }
    sum_h2_ += h * h;
    ++count_;
  }
  int count() const { return count_; }
  const Eigen::Vector3d& normal() const { return normal_; }

  /// The normal matrix of the quadric's six unknowns and its right-hand side.
  Eigen::Matrix<double, 6, 6> normalMatrix() const;
  Eigen::Matrix<double, 6, 1> rhs() const;
  double sumOfSquaredHeights() const { return sum_h2_; }

 private:
  Eigen::Vector3d normal_, e1_, e2_;
  Eigen::Vector3d reference_ = Eigen::Vector3d::Zero();
  // Upper triangle of the normal matrix, row by row (21 sums), in plain doubles: an Eigen rank
  // update per point costs a third more.
  std::array<double, 21> products_{};
  std::array<double, 6> rhs_{};
  double sum_h2_ = 0.0;
  int count_ = 0;
};

/// A plane and a quadric fitted to the same heights.
struct HeightFit {
  int count = 0;                  ///< points
  double plane_residual = 0.0;    ///< sum of squared residuals off the plane (m^2)
  double quadric_residual = 0.0;  ///< sum of squared residuals off the quadric (m^2)
  /// The quadric's larger principal curvature magnitude at its vertex (1/m): 1 / radius for a
  /// sphere or a cylinder seen along its normal, 0 for a plane.
  double curvature = 0.0;

  /// Whether there are enough points to tell a quadric from a plane: twice its unknowns.
  bool reliable() const { return count >= 12; }
  double planeRms() const;
  double quadricRms() const;
  /// How many times better the quadric fits than the plane, as a ratio of RMS residuals.
  double planeToQuadricRms() const;
};

/// Fits both to `sums`. All zero when there are fewer than 6 points.
HeightFit fitHeights(const HeightSums& sums);

}  // namespace shapesense
