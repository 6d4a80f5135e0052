#include "shapesense/core/recognition/surface_clusters.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "cloud_index.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/geometry/union_find.h"

namespace shapesense {
namespace {

std::vector<FaceRectangle> supports(const FlatFaces& faces, const SurfaceClusterParams& params) {
  std::vector<FaceRectangle> out;
  for (const FaceRectangle& face : faces.faces)
    if (std::max(face.sides[0], face.sides[1]) >= params.min_support_side_m) out.push_back(face);
  return out;
}

bool overSupport(const Eigen::Vector3f& offset, const FaceRectangle& support,
                 const SurfaceClusterParams& params) {
  for (int k = 0; k < 2; ++k)
    if (std::abs(offset.dot(support.axes[k])) > 0.5f * support.sides[k] + params.support_margin_m)
      return false;
  return true;
}

bool onSupport(const Eigen::Vector3f& point, const FaceRectangle& support,
               const SurfaceClusterParams& params) {
  const Eigen::Vector3f offset = point - support.centre;
  return std::abs(offset.dot(support.normal)) <= params.support_distance_m &&
         overSupport(offset, support, params);
}

// How many of `points` are its foot on `support` (within the standing reach above it), or -1
// when more than a few lie below it.
int footOn(const std::vector<Eigen::Vector3f>& points, const FaceRectangle& support,
           const SurfaceClusterParams& params) {
  constexpr float kBelowShare = 0.05f;
  int foot = 0;
  int below = 0;
  for (const Eigen::Vector3f& point : points) {
    const Eigen::Vector3f offset = point - support.centre;
    const float height = offset.dot(support.normal);
    if (height < -params.support_distance_m)
      ++below;
    else if (height <= params.standing_reach_m && overSupport(offset, support, params))
      ++foot;
  }
  if (static_cast<float>(below) > kBelowShare * static_cast<float>(points.size())) return -1;
  return foot;
}

SurfaceCloud pointsOffSupports(const SurfaceCloud& surface,
                               const std::vector<FaceRectangle>& supports,
                               const SurfaceClusterParams& params) {
  SurfaceCloud out;
  for (std::size_t i = 0; i < surface.size(); ++i) {
    const Eigen::Vector3f& point = surface.points[i];
    const bool supported = std::any_of(supports.begin(), supports.end(),
                                       [&](const auto& s) { return onSupport(point, s, params); });
    if (supported) continue;
    out.points.push_back(point);
    out.normals.push_back(surface.normals[i]);
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

bool similarSize(float model, float cluster, float slack) {
  constexpr float kAbsoluteSlack = 0.02f;
  return std::abs(model - cluster) <= slack * model + kAbsoluteSlack;
}

// The points of `surface` (seen from the origin) whose normal lies within max_view_angle_deg of
// the line of sight.
SurfaceCloud facingViewer(const SurfaceCloud& surface, const SurfaceClusterParams& params) {
  const float least_cos = std::cos(params.max_view_angle_deg * std::numbers::pi_v<float> / 180.0f);
  SurfaceCloud out;
  for (std::size_t i = 0; i < surface.size(); ++i) {
    const Eigen::Vector3f& p = surface.points[i];
    if (std::abs(surface.normals[i].dot(p)) < least_cos * p.norm()) continue;
    out.points.push_back(p);
    out.normals.push_back(surface.normals[i]);
  }
  return out;
}

// The turn about `up` (from `u` towards `v`) of the upright faces among `normals`, up to
// quarter turns: the circular mean of four times their angles. None when too few of the
// normals are upright or their turns disagree.
std::optional<float> uprightFacesTurn(const std::vector<Eigen::Vector3f>& normals,
                                      const Eigen::Vector3f& up, const Eigen::Vector3f& u,
                                      const Eigen::Vector3f& v) {
  constexpr float kUprightSin = 0.87f;  // within 30 deg of upright
  constexpr float kLeastShare = 0.1f;
  constexpr float kLeastAgreement = 0.5f;
  float c = 0.0f, s = 0.0f;
  int upright = 0;
  for (const Eigen::Vector3f& n : normals) {
    const Eigen::Vector3f across = n - n.dot(up) * up;
    if (across.norm() < kUprightSin) continue;
    const float angle = std::atan2(across.dot(v), across.dot(u));
    c += std::cos(4.0f * angle);
    s += std::sin(4.0f * angle);
    ++upright;
  }
  if (upright == 0 ||
      static_cast<float>(upright) < kLeastShare * static_cast<float>(normals.size()))
    return std::nullopt;
  if (std::hypot(c, s) < kLeastAgreement * static_cast<float>(upright)) return std::nullopt;
  return 0.25f * std::atan2(s, c);
}

}  // namespace

OrientedBox standingBox(const SurfaceCloud& surface, const Eigen::Vector4f& support,
                        const SurfaceClusterParams& params) {
  // Beyond a gap, a tenth of the points is a part of the object, not a trail.
  constexpr double kDenseShare = 0.1;
  const SurfaceCloud facing = facingViewer(surface, params);
  const SurfaceCloud& seen = facing.empty() ? surface : facing;
  OrientedBox box;
  if (seen.empty()) return box;
  const Eigen::Vector3f up = support.head<3>();
  const Eigen::Vector3f u = up.unitOrthogonal();
  const Eigen::Vector3f v = up.cross(u);
  Eigen::Vector3f side = u;
  if (const std::optional<float> turn = uprightFacesTurn(seen.normals, up, u, v)) {
    side = std::cos(*turn) * u + std::sin(*turn) * v;
  } else {
    std::vector<cv::Point2f> footprint;
    footprint.reserve(seen.size());
    for (const auto& p : seen.points) footprint.emplace_back(u.dot(p), v.dot(p));
    std::array<cv::Point2f, 4> corners;
    cv::minAreaRect(footprint).points(corners.data());
    const cv::Point2f edge = corners[1] - corners[0];
    if (std::hypot(edge.x, edge.y) > 0.0f) side = (edge.x * u + edge.y * v).normalized();
  }
  box.axes.col(0) = side;
  box.axes.col(1) = up.cross(side);
  box.axes.col(2) = up;
  Eigen::Vector3f lo, hi;
  std::vector<double> along(seen.size());
  for (int k = 0; k < 3; ++k) {
    for (std::size_t i = 0; i < seen.size(); ++i) along[i] = box.axes.col(k).dot(seen.points[i]);
    const auto [low, high] = denseRange(along, params.standing_box_gap_m, kDenseShare);
    lo[k] = static_cast<float>(low);
    hi[k] = static_cast<float>(high);
  }
  // From the plane up: the part of the foot within the support's band is not in the surface.
  lo.z() = -support.w();
  box.size = hi - lo;
  box.centre = box.axes * (0.5f * (lo + hi));
  return box;
}

std::optional<Eigen::Vector4f> supportBeneath(const std::vector<Eigen::Vector3f>& points,
                                              const FlatFaces& faces,
                                              const SurfaceClusterParams& params) {
  constexpr float kFootShare = 0.01f;
  const FaceRectangle* beneath = nullptr;
  const int least =
      std::max(1, static_cast<int>(std::ceil(kFootShare * static_cast<float>(points.size()))));
  int most = least - 1;
  const std::vector<FaceRectangle> candidates = supports(faces, params);
  for (const FaceRectangle& support : candidates) {
    const int foot = footOn(points, support, params);
    if (foot > most) {
      most = foot;
      beneath = &support;
    }
  }
  if (beneath == nullptr) return std::nullopt;
  return Eigen::Vector4f(beneath->normal.x(), beneath->normal.y(), beneath->normal.z(),
                         -beneath->normal.dot(beneath->centre));
}

std::vector<SurfaceCluster> surfaceClusters(const SurfaceCloud& surface, const FlatFaces& faces,
                                            const SurfaceClusterParams& params) {
  const SurfaceCloud off = pointsOffSupports(surface, supports(faces, params), params);
  const std::vector<Eigen::Vector3f>& points = off.points;
  const std::vector<int> roots = clusterRoots(points, params.link_distance_m);
  // A root is its cluster's smallest index, so clusters come in the order of their first point.
  std::vector<int> cluster_of_root(points.size(), -1);
  std::vector<SurfaceCloud> members;
  for (std::size_t i = 0; i < points.size(); ++i) {
    int& cluster = cluster_of_root[static_cast<std::size_t>(roots[i])];
    if (cluster < 0) {
      cluster = static_cast<int>(members.size());
      members.emplace_back();
    }
    members[static_cast<std::size_t>(cluster)].points.push_back(points[i]);
    members[static_cast<std::size_t>(cluster)].normals.push_back(off.normals[i]);
  }
  std::vector<SurfaceCluster> out;
  for (const auto& cluster : members) {
    if (static_cast<int>(cluster.size()) < params.min_points) continue;
    SurfaceCluster& added = out.emplace_back();
    added.box = principalBox(cluster.points);
    if (const auto support = supportBeneath(cluster.points, faces, params))
      added.standing_box = standingBox(cluster, *support, params);
  }
  return out;
}

bool similarBoxSizes(const OrientedBox& model, const OrientedBox& cluster, float slack) {
  const Eigen::Vector3f a = sortedSizes(model), b = sortedSizes(cluster);
  for (int k = 0; k < 3; ++k)
    if (!similarSize(a[k], b[k], slack)) return false;
  return true;
}

bool similarStandingSizes(const OrientedBox& model, const OrientedBox& cluster, float slack) {
  const auto shorter = [](const OrientedBox& b) { return std::min(b.size.x(), b.size.y()); };
  const auto longer = [](const OrientedBox& b) { return std::max(b.size.x(), b.size.y()); };
  return similarSize(model.size.z(), cluster.size.z(), slack) &&
         similarSize(shorter(model), shorter(cluster), slack) &&
         similarSize(longer(model), longer(cluster), slack);
}

std::vector<Eigen::Isometry3f> standingPoses(const OrientedBox& model, const OrientedBox& cluster) {
  const auto bottom = [](const OrientedBox& b) {
    return Eigen::Vector3f(b.centre - 0.5f * b.size.z() * b.axes.col(2));
  };
  std::vector<Eigen::Isometry3f> poses;
  for (int quarter = 0; quarter < 4; ++quarter) {
    const float angle = static_cast<float>(quarter) * 0.5f * std::numbers::pi_v<float>;
    const Eigen::Matrix3f about_up =
        Eigen::AngleAxisf(angle, Eigen::Vector3f::UnitZ()).toRotationMatrix();
    Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
    pose.linear() = cluster.axes * about_up * model.axes.transpose();
    pose.translation() = bottom(cluster) - pose.linear() * bottom(model);
    poses.push_back(pose);
  }
  return poses;
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
