#include "planes/curved_regions.h"

#include <array>
#include <cmath>
#include <map>
#include <utility>
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

constexpr int kMinSamples = 12;  // twice the quadric's unknowns

double rms(const LeastSquares& fit, int count) {
  return std::sqrt(fit.residual / std::max(count, 1));
}

struct Frame {
  Eigen::Vector3d normal, e1, e2;
  explicit Frame(const Eigen::Vector3d& n) : normal(n), e1(n.unitOrthogonal()), e2(n.cross(e1)) {}
};

// A region's plane and quadric fits over its own samples, in its plane's frame.
struct OwnFit {
  int count = 0;
  double plane_residual = 0.0;
  double plane_to_quadric_rms = 1.0;
  double curvature = 0.0;

  explicit OwnFit(const QuadricSums& s) : count(s.count) {
    if (count < kMinSamples) return;
    const LeastSquares plane = solveLast(s, 3), quadric = solveLast(s, 6);
    plane_residual = plane.residual;
    plane_to_quadric_rms = std::sqrt(plane.residual / std::max(quadric.residual, 1e-18));
    curvature = largestCurvature(quadric.solution);
  }

  // Whether its quadric bends more than a flat surface can, however little better than the
  // plane it fits.
  bool bends(const PlaneLabelingParams& params) const {
    return count >= kMinSamples && curvature > params.max_plane_curvature_per_m;
  }
  // Whether the region is curved on its own: it bends and the quadric fits it markedly better.
  bool curved(const PlaneLabelingParams& params) const {
    return bends(params) && plane_to_quadric_rms >= params.curved_rms_ratio;
  }
};

// The candidate regions' own sums, the candidate root of each sample (-1 for none) and how
// often two candidates' samples lie within two grid steps of each other along a row or column.
struct RegionSamples {
  std::vector<QuadricSums> sums;
  cv::Mat region;  // CV_32SC1, the grid's size
  std::map<std::pair<int, int>, int> contacts;
};

RegionSamples gatherSamples(const PlaneSampleGrid& grid, const cv::Mat& region_labels,
                            const std::vector<int>& root, const std::vector<bool>& candidate,
                            const std::vector<Frame>& frames) {
  constexpr int kReach = 2;
  const int count = static_cast<int>(root.size());
  const int rows = grid.points.rows, cols = grid.points.cols;
  RegionSamples out;
  out.sums.resize(root.size());
  out.region.create(rows, cols, CV_32SC1);
  out.region.setTo(-1);
  for (int r = 0; r < rows; ++r) {
    const auto* label_row = region_labels.ptr<std::uint16_t>(grid.offset + r * grid.step);
    const auto* point_row = grid.points.ptr<cv::Vec3f>(r);
    auto* region_row = out.region.ptr<int>(r);
    for (int c = 0; c < cols; ++c) {
      const int label = label_row[grid.offset + c * grid.step];
      if (!label || label > count) continue;
      const int k = root[label - 1];
      if (!candidate[k]) continue;
      const cv::Vec3f& x = point_row[c];
      if (!std::isfinite(x[2])) continue;
      out.sums[k].add({x[0], x[1], x[2]}, frames[k].normal, frames[k].e1, frames[k].e2);
      region_row[c] = k;
      for (int s = 1; s <= kReach; ++s) {
        const int left = c >= s ? region_row[c - s] : -1;
        const int above = r >= s ? out.region.ptr<int>(r - s)[c] : -1;
        for (const int other : {left, above})
          if (other >= 0 && other != k) ++out.contacts[{std::min(k, other), std::max(k, other)}];
      }
    }
  }
  return out;
}

// Two regions that meet at a shallow angle are two pieces of one curved surface (a bin or a
// column cut into facets) when each bends on its own, and one quadric fits their samples
// together about as well as their two planes fit them, and bends more than a flat surface
// can. Two flat faces at a shallow crease fail the first test even where the sensor's noise
// at range lets a quadric pass for the crease.
bool formOneCurvedSurface(const PlaneSampleGrid& grid, const cv::Mat& sample_region, int a, int b,
                          const OwnFit& fit_a, const OwnFit& fit_b, const Frame& frame_a,
                          const Frame& frame_b, const PlaneLabelingParams& params) {
  if (!fit_a.bends(params) || !fit_b.bends(params)) return false;
  if (frame_a.normal.dot(frame_b.normal) <
      std::cos(params.curved_pair_max_angle_deg * M_PI / 180.0))
    return false;
  const Frame joint((frame_a.normal + frame_b.normal).normalized());
  QuadricSums both;
  for (int r = 0; r < sample_region.rows; ++r) {
    const auto* region_row = sample_region.ptr<int>(r);
    const auto* point_row = grid.points.ptr<cv::Vec3f>(r);
    for (int c = 0; c < sample_region.cols; ++c) {
      if (region_row[c] != a && region_row[c] != b) continue;
      const cv::Vec3f& x = point_row[c];
      both.add({x[0], x[1], x[2]}, joint.normal, joint.e1, joint.e2);
    }
  }
  const double two_planes_rms =
      std::sqrt((fit_a.plane_residual + fit_b.plane_residual) / (fit_a.count + fit_b.count));
  const LeastSquares quadric = solveLast(both, 6);
  return rms(quadric, both.count) <= params.curved_pair_rms_factor * two_planes_rms &&
         largestCurvature(quadric.solution) > params.max_plane_curvature_per_m;
}

}  // namespace

std::vector<bool> curvedRegions(const PlaneSampleGrid& grid, const cv::Mat& region_labels,
                                const std::vector<int>& root, const std::vector<bool>& candidate,
                                const std::vector<Eigen::Vector3d>& normals,
                                const PlaneLabelingParams& params) {
  if (params.max_plane_curvature_per_m <= 0.0) return {};
  const std::size_t count = root.size();
  std::vector<Frame> frames;
  frames.reserve(count);
  for (std::size_t k = 0; k < count; ++k)
    frames.emplace_back(candidate[k] ? normals[k] : Eigen::Vector3d::UnitZ());
  const RegionSamples samples = gatherSamples(grid, region_labels, root, candidate, frames);
  std::vector<OwnFit> fits;
  fits.reserve(count);
  std::vector<bool> curved(count, false);
  for (std::size_t k = 0; k < count; ++k) {
    fits.emplace_back(samples.sums[k]);
    curved[k] = candidate[k] && fits[k].curved(params);
  }
  if (params.curved_pair_rms_factor <= 0.0) return curved;
  constexpr int kMinContacts = 3;
  for (const auto& [pair, contacts] : samples.contacts) {
    const auto [a, b] = pair;
    if (contacts >= kMinContacts && formOneCurvedSurface(grid, samples.region, a, b, fits[a],
                                                         fits[b], frames[a], frames[b], params))
      curved[a] = curved[b] = true;
  }
  return curved;
}

}  // namespace shapesense::labeling
