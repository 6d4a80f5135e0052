// Step 4b of HoughPlaneDetector::detect, and the test the leftover step shares (see
// hough_detector_steps.h): planes whose samples lie on two faces at a crease, split in two.
#include <algorithm>
#include <cmath>
#include <vector>

#include "planes/hough_detector_steps.h"

namespace shapesense {
namespace {

Eigen::Vector3d pointOf(const PlaneSampleGrid& grid, int i) {
  const cv::Vec3f& p = grid.points.ptr<cv::Vec3f>(0)[i];
  return {p[0], p[1], p[2]};
}

double distanceTo(const PlaneFit& plane, const Eigen::Vector3d& x) {
  return std::abs(plane.normal.dot(x) + plane.d);
}

}  // namespace

std::optional<TwoPlanes> twoFaces(const std::vector<int>& members, const PlaneSampleGrid& grid,
                                  const PlaneFit& one, const HoughPlaneParams& P) {
  constexpr double kFaceSamplesPerPlaneSamples = 2.0;
  if (P.two_face_gain <= 0.0 || members.empty() || !one.valid) return std::nullopt;
  std::vector<Eigen::Vector3d> points;
  points.reserve(members.size());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const int i : members) {
    points.push_back(pointOf(grid, i));
    sum += points.back();
  }
  const std::optional<TwoPlaneFit> two =
      bestTwoPlanes(points, sum / static_cast<double>(points.size()));
  if (!two) return std::nullopt;
  // The fit counts every stride-th member.
  const double min_face =
      kFaceSamplesPerPlaneSamples * P.min_plane_samples / static_cast<double>(two->stride);
  if (two->planes.a.count < min_face || two->planes.b.count < min_face ||
      one.rms_m < P.two_face_gain * two->rms())
    return std::nullopt;
  return two->planes;
}

void labelTwoFaces(const TwoPlanes& faces, const std::vector<int>& members,
                   const PlaneSampleGrid& grid, const std::vector<double>& member_tol,
                   std::vector<PlaneHypothesis>& planes, cv::Mat& sample_labels) {
  const int a = static_cast<int>(planes.size());
  int* lab = sample_labels.ptr<int>(0);
  for (std::size_t k = 0; k < members.size(); ++k) {
    const Eigen::Vector3d x = pointOf(grid, members[k]);
    const double to_a = distanceTo(faces.a, x), to_b = distanceTo(faces.b, x);
    if (std::min(to_a, to_b) <= member_tol[k]) lab[members[k]] = to_b < to_a ? a + 1 : a;
  }
  planes.push_back({faces.a.normal, faces.a.d});
  planes.push_back({faces.b.normal, faces.b.d});
}

void splitTwoFacedPlanes(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                         std::vector<PlaneHypothesis>& planes, const HoughPlaneParams& P) {
  if (P.two_face_gain <= 0.0) return;
  const int N = grid.points.rows * grid.points.cols;
  int* lab = sample_labels.ptr<int>(0);
  std::vector<std::vector<int>> members(planes.size());
  for (int i = 0; i < N; ++i)
    if (lab[i] >= 0) members[static_cast<std::size_t>(lab[i])].push_back(i);
  for (std::size_t plane = 0; plane < members.size(); ++plane) {
    PlaneMoments moments;
    for (const int i : members[plane]) moments.add(pointOf(grid, i));
    const std::optional<TwoPlanes> faces = twoFaces(members[plane], grid, moments.fit(), P);
    if (!faces) continue;
    const int b = static_cast<int>(planes.size());
    planes[plane] = {faces->a.normal, faces->a.d};
    planes.push_back({faces->b.normal, faces->b.d});
    for (const int i : members[plane]) {
      const Eigen::Vector3d x = pointOf(grid, i);
      if (distanceTo(faces->b, x) < distanceTo(faces->a, x)) lab[i] = b;
    }
  }
}

}  // namespace shapesense
