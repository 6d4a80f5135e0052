#include "planes/curved_regions.h"

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace shapesense::labeling {
namespace {

// Least-squares sums of the height h of each sample above the region's plane, in the plane's
// own coordinates (a, b) around a reference point, for the quadric
// h = q0 a^2 + q1 a b + q2 b^2 + q3 a + q4 b + q5 and for its plane part (the last three).
struct QuadricSums {
  // Upper triangle of the normal matrix, row by row (21 sums), in plain doubles: an Eigen rank
  // update per sample cost a third more.
  std::array<double, 21> products{};
  std::array<double, 6> rhs{};
  double sum_h2 = 0.0;
  int count = 0;
  bool has_reference = false;
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();

  void add(const Eigen::Vector3d& x, const Eigen::Vector3d& n, const Eigen::Vector3d& e1,
           const Eigen::Vector3d& e2) {
    if (!has_reference) {
      reference = x;
      has_reference = true;
    }
    const Eigen::Vector3d p = x - reference;
    const double a = p.dot(e1), b = p.dot(e2), h = p.dot(n);
    const double f[6] = {a * a, a * b, b * b, a, b, 1.0};
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) products[k++] += f[i] * f[j];
      rhs[i] += h * f[i];
    }
    sum_h2 += h * h;
    ++count;
  }

  Eigen::Matrix<double, 6, 6> normalMatrix() const {
    Eigen::Matrix<double, 6, 6> m;
    int k = 0;
    for (int i = 0; i < 6; ++i)
      for (int j = i; j < 6; ++j) m(i, j) = m(j, i) = products[k++];
    return m;
  }
  Eigen::Matrix<double, 6, 1> rhsVector() const {
    return Eigen::Map<const Eigen::Matrix<double, 6, 1>>(rhs.data());
  }
};

// The least-squares solution over the system's last `dims` unknowns (6: the quadric, 3: the
// plane) and its residual sum of squares.
struct LeastSquares {
  Eigen::VectorXd solution;
  double residual = 0.0;
};

LeastSquares solveLast(const QuadricSums& s, int dims) {
  const Eigen::MatrixXd m = s.normalMatrix();
  const Eigen::MatrixXd sub = m.bottomRightCorner(dims, dims);
  const Eigen::VectorXd rhs = s.rhsVector().tail(dims);
  LeastSquares fit;
  fit.solution = sub.ldlt().solve(rhs);
  fit.residual = std::max(0.0, s.sum_h2 - fit.solution.dot(rhs));
  return fit;
}

// The larger principal curvature magnitude of a fitted quadric h = q0 a^2 + q1 a b + q2 b^2 + ...
double largestCurvature(const Eigen::VectorXd& q) {
  Eigen::Matrix2d hessian;
  hessian << 2.0 * q[0], q[1], q[1], 2.0 * q[2];
  const Eigen::Vector2d k = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(hessian).eigenvalues();
  return std::max(std::fabs(k[0]), std::fabs(k[1]));
}

bool isCurved(const QuadricSums& s, const PlaneLabelingParams& params) {
  constexpr int kMinSamples = 12;  // twice the quadric's unknowns
  if (s.count < kMinSamples) return false;
  const LeastSquares plane = solveLast(s, 3), quadric = solveLast(s, 6);
  const double ratio = std::sqrt(plane.residual / std::max(quadric.residual, 1e-18));
  return ratio >= params.curved_rms_ratio &&
         largestCurvature(quadric.solution) > params.max_plane_curvature_per_m;
}

}  // namespace

std::vector<bool> curvedRegions(const PlaneSampleGrid& grid, const cv::Mat& region_labels,
                                const std::vector<int>& root, const std::vector<bool>& candidate,
                                const std::vector<Eigen::Vector3d>& normals,
                                const PlaneLabelingParams& params) {
  if (params.max_plane_curvature_per_m <= 0.0) return {};
  const std::size_t count = root.size();
  struct Axes {
    Eigen::Vector3d e1, e2;
  };
  std::vector<Axes> axes(count);
  for (std::size_t k = 0; k < count; ++k) {
    if (!candidate[k]) continue;
    axes[k].e1 = normals[k].unitOrthogonal();
    axes[k].e2 = normals[k].cross(axes[k].e1);
  }
  std::vector<QuadricSums> sums(count);
  for (int r = 0; r < grid.points.rows; ++r) {
    const auto* label_row = region_labels.ptr<std::uint16_t>(grid.offset + r * grid.step);
    const auto* point_row = grid.points.ptr<cv::Vec3f>(r);
    for (int c = 0; c < grid.points.cols; ++c) {
      const int label = label_row[grid.offset + c * grid.step];
      if (!label || label > static_cast<int>(count)) continue;
      const int k = root[label - 1];
      if (!candidate[k]) continue;
      const cv::Vec3f& x = point_row[c];
      if (!std::isfinite(x[2])) continue;
      sums[k].add({x[0], x[1], x[2]}, normals[k], axes[k].e1, axes[k].e2);
    }
  }
  std::vector<bool> curved(count, false);
  for (std::size_t k = 0; k < count; ++k) curved[k] = candidate[k] && isCurved(sums[k], params);
  return curved;
}

}  // namespace shapesense::labeling
