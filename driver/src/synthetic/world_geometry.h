#pragma once
// Angles, poses and planes of the scene's world frame (z up, floor at z = 0, metres).

#include <numbers>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace shapesense::synthetic::detail {

// Not core's degToRad: that one multiplies by pi / 180 and so rounds differently, and every
// scene is defined by the bits these conversions give.
inline double degToRad(double deg) { return deg * std::numbers::pi / 180.0; }
inline double radToDeg(double rad) { return rad * 180.0 / std::numbers::pi; }

/// The plane (n, d), n.X + d = 0, through `point_local` with normal `n_local`, in world
/// coordinates.
inline Eigen::Vector4d worldPlane(const Eigen::Isometry3d& world_from_local,
                                  const Eigen::Vector3d& n_local,
                                  const Eigen::Vector3d& point_local) {
  const Eigen::Vector3d n = world_from_local.linear() * n_local;
  const Eigen::Vector3d p = world_from_local * point_local;
  return {n.x(), n.y(), n.z(), -n.dot(p)};
}

/// At `position`, turned by `yaw` about the world (or parent) z axis.
inline Eigen::Isometry3d poseAt(const Eigen::Vector3d& position, double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = position;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

}  // namespace shapesense::synthetic::detail
