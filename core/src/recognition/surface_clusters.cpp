#include "shapesense/core/recognition/surface_clusters.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "cloud_index.h"
#include "shapesense/core/geometry/union_find.h"

namespace shapesense {
namespace {

std::vector<FaceRectangle> supports(const FlatFaces& faces, const SurfaceClusterParams& params) {
  std::vector<FaceRectangle> out;
  for (const FaceRectangle& face : faces.faces)
    if (std::max(face.sides[0], face.sides[1]) >= params.min_support_side_m) out.push_back(face);
  return out;
}

bool onSupport(const Eigen::Vector3f& point, const FaceRectangle& support,
               const SurfaceClusterParams& params) {
  const Eigen::Vector3f offset = point - support.centre;
  if (std::abs(offset.dot(support.normal)) > params.support_distance_m) return false;
  for (int k = 0; k < 2; ++k)
    if (std::abs(offset.dot(support.axes[k])) > 0.5f * support.sides[k] + params.support_margin_m)
      return false;
  return true;
}

std::vector<Eigen::Vector3f> pointsOffSupports(const SurfaceCloud& surface,
                                               const std::vector<FaceRectangle>& supports,
                                               const SurfaceClusterParams& params) {
  std::vector<Eigen::Vector3f> out;
  for (const Eigen::Vector3f& point : surface.points) {
    const bool supported = std::any_of(supports.begin(), supports.end(),
                                       [&](const auto& s) { return onSupport(point, s, params); });
    if (!supported) out.push_back(point);
  }
  return out;
}

// The root of each point's cluster: points within the link distance of each other joined.
std::vector<int> clusterRoots(const std::vector<Eigen::Vector3f>& points, float link_distance) {
  std::vector<int> parent(points.size());
  resetSets(parent);
  const detail::PointGrid grid(points, link_distance);
  grid.forEachPoint(link_distance, {},
                    [&](std::uint32_t i, const std::vector<std::uint32_t>& neighbours) {
                      for (const std::uint32_t j : neighbours)
                        unite(parent, static_cast<int>(i), static_cast<int>(j));
                    });
  for (std::size_t i = 0; i < points.size(); ++i) parent[i] = findRoot(parent, static_cast<int>(i));
  return parent;
}

Eigen::Vector3f sortedSizes(const OrientedBox& box) {
  Eigen::Vector3f sizes = box.size;
  std::sort(sizes.data(), sizes.data() + 3);
  return sizes;
}

}  // namespace

std::vector<OrientedBox> surfaceClusters(const SurfaceCloud& surface, const FlatFaces& faces,
                                         const SurfaceClusterParams& params) {
  const std::vector<Eigen::Vector3f> points =
      pointsOffSupports(surface, supports(faces, params), params);
  const std::vector<int> roots = clusterRoots(points, params.link_distance_m);
  // A root is its cluster's smallest index, so clusters come in the order of their first point.
  std::vector<int> cluster_of_root(points.size(), -1);
  std::vector<std::vector<Eigen::Vector3f>> members;
  for (std::size_t i = 0; i < points.size(); ++i) {
    int& cluster = cluster_of_root[static_cast<std::size_t>(roots[i])];
    if (cluster < 0) {
      cluster = static_cast<int>(members.size());
      members.emplace_back();
    }
    members[static_cast<std::size_t>(cluster)].push_back(points[i]);
  }
  std::vector<OrientedBox> out;
  for (const auto& cluster : members)
    if (static_cast<int>(cluster.size()) >= params.min_points) out.push_back(principalBox(cluster));
  return out;
}

bool similarBoxSizes(const OrientedBox& model, const OrientedBox& cluster, float slack) {
  constexpr float kAbsoluteSlack = 0.02f;
  const Eigen::Vector3f a = sortedSizes(model), b = sortedSizes(cluster);
  for (int k = 0; k < 3; ++k)
    if (std::abs(a[k] - b[k]) > slack * a[k] + kAbsoluteSlack) return false;
  return true;
}

std::vector<Eigen::Isometry3f> boxAlignedPoses(const OrientedBox& model,
                                               const OrientedBox& cluster) {
  static constexpr std::array<std::array<int, 3>, 6> kOrders{
      {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  std::vector<Eigen::Isometry3f> poses;
  for (const auto& order : kOrders)
    for (int signs = 0; signs < 8; ++signs) {
      // Model axis k onto cluster axis order[k], flipped where the sign's bit is set.
      Eigen::Matrix3f axis_map = Eigen::Matrix3f::Zero();
      for (int k = 0; k < 3; ++k)
        axis_map(order[static_cast<std::size_t>(k)], k) = (signs >> k) & 1 ? -1.0f : 1.0f;
      const Eigen::Matrix3f turn = cluster.axes * axis_map * model.axes.transpose();
      if (turn.determinant() < 0.0f) continue;
      Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
      pose.linear() = turn;
      pose.translation() = cluster.centre - turn * model.centre;
      poses.push_back(pose);
    }
  return poses;
}

}  // namespace shapesense
