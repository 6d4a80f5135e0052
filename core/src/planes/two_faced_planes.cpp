#include "planes/two_faced_planes.h"

namespace shapesense {

void gatherSamplePoints(const PlaneSampleGrid& grid, const std::vector<int>& members,
                        std::vector<Eigen::Vector3d>& points) {
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  points.clear();
  for (const int i : members) points.emplace_back(pts[i][0], pts[i][1], pts[i][2]);
}

namespace {

// Each face holds twice min_plane_samples (see twoFaces).
double faceSamples(const HoughPlaneParams& P) { return 2.0 * P.min_plane_samples; }

}  // namespace

bool mayBeTwoFaces(std::size_t count, const HoughPlaneParams& P) {
  return P.two_face_gain > 0.0 && TwoPlaneFit::mayHoldFacesOf(count, faceSamples(P));
}

std::optional<TwoPlanes> twoFaces(std::span<const Eigen::Vector3d> points, const PlaneFit& one,
                                  const HoughPlaneParams& P) {
  if (!mayBeTwoFaces(points.size(), P) || points.empty() || !one.valid) return std::nullopt;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& x : points) sum += x;
  const std::optional<TwoPlaneFit> two =
      bestTwoPlanes(points, sum / static_cast<double>(points.size()));
  if (!two || !two->facesHoldAtLeast(faceSamples(P)) || one.rms_m < P.two_face_gain * two->rms())
    return std::nullopt;
  return two->planes;
}

void labelNearerFace(const TwoPlanes& faces, const std::vector<int>& members,
                     std::span<const Eigen::Vector3d> points, int label_a, int label_b,
                     const std::vector<double>* member_tol, cv::Mat& sample_labels) {
  int* lab = sample_labels.ptr<int>(0);
  for (std::size_t k = 0; k < members.size(); ++k) {
    const double to_a = faces.a.distance(points[k]), to_b = faces.b.distance(points[k]);
    const bool on_b = to_b < to_a;  // TwoPlanes::nearerB
    if (member_tol && (on_b ? to_b : to_a) > (*member_tol)[k]) continue;
    lab[members[k]] = on_b ? label_b : label_a;
  }
}

void splitTwoFacedPlanes(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                         std::vector<PlaneHypothesis>& planes, const HoughPlaneParams& P) {
  if (P.two_face_gain <= 0.0) return;
  const int N = grid.points.rows * grid.points.cols;
  const int* lab = sample_labels.ptr<int>(0);
  std::vector<std::vector<int>> members(planes.size());
  for (int i = 0; i < N; ++i)
    if (lab[i] >= 0) members[static_cast<std::size_t>(lab[i])].push_back(i);
  std::vector<Eigen::Vector3d> points;
  for (std::size_t plane = 0; plane < members.size(); ++plane) {
    if (!mayBeTwoFaces(members[plane].size(), P)) continue;
    gatherSamplePoints(grid, members[plane], points);
    PlaneMoments moments;
    for (const Eigen::Vector3d& x : points) moments.add(x);
    const std::optional<TwoPlanes> faces = twoFaces(points, moments.fit(), P);
    if (!faces) continue;
    const int b = static_cast<int>(planes.size());
    planes[plane] = {faces->a.normal, faces->a.d};
    planes.push_back({faces->b.normal, faces->b.d});
    labelNearerFace(*faces, members[plane], points, static_cast<int>(plane), b, nullptr,
                    sample_labels);
  }
}

}  // namespace shapesense
