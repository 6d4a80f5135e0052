// Free spots for objects: on the table top, or on the floor beside or in front of the table.

#include <algorithm>
#include <numbers>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

/// A free spot on the table top for a footprint of `radius`, as a pose on the top surface
/// with random yaw; nullopt when none is found.
std::optional<Eigen::Isometry3d> LayoutBuilder::tableSpot(double radius) {
  const Eigen::Vector2d reach = table_size_ / 2.0 - Eigen::Vector2d::Constant(radius + 0.01);
  if (reach.minCoeff() < 0.0) return std::nullopt;
  for (int attempt = 0; attempt < 200; ++attempt) {
    const Eigen::Vector2d c = rng_.uniform2(-reach, reach);
    if (!isFree(table_footprints_, c, radius)) continue;
    table_footprints_.push_back({c, radius});
    const Eigen::Isometry3d table_top =
        poseAt({table_center_.x(), table_center_.y(), table_height_}, table_yaw_);
    return table_top *
           poseAt({c.x(), c.y(), 0.0}, rng_.uniform(-std::numbers::pi, std::numbers::pi));
  }
  return std::nullopt;
}

/// A free floor spot beside or in front of the table, in the camera's view, for a footprint of
/// `radius` and an object `height` tall; nullopt when none is found.
std::optional<Eigen::Isometry3d> LayoutBuilder::floorSpot(double radius, double height) {
  for (int attempt = 0; attempt < 200; ++attempt) {
    const std::optional<Eigen::Vector2d> c = floorCandidate(radius, height);
    if (!c) continue;
    floor_footprints_.push_back({*c, radius});
    return poseAt({c->x(), c->y(), 0.0}, rng_.uniform(-std::numbers::pi, std::numbers::pi));
  }
  return std::nullopt;
}

/// One drawn floor position (world x, y) beside or in front of the table; nullopt when it is
/// outside the room, at the robot's feet, taken, or its top is not well inside the image.
std::optional<Eigen::Vector2d> LayoutBuilder::floorCandidate(double radius, double height) {
  Eigen::Vector2d local;  // table frame
  const double gap = rng_.uniform(0.05, 0.6);
  if (rng_.chance(0.7)) {
    local = {rng_.sign() * (table_size_.x() / 2 + radius + gap),
             rng_.uniform(-0.5, 0.5) * table_size_.y()};
  } else {
    local = {rng_.uniform(-0.5, 0.5) * table_size_.x(), -(table_size_.y() / 2 + radius + gap)};
  }
  const Eigen::Vector2d c = table_center_ + Eigen::Rotation2Dd(table_yaw_) * local;
  if ((c - room_min_).minCoeff() < radius + 0.02 || (room_max_ - c).minCoeff() < radius + 0.02)
    return std::nullopt;
  if ((c - camera_position_.head<2>()).norm() < radius + 0.45) return std::nullopt;
  if (!isFree(floor_footprints_, c, radius)) return std::nullopt;
  const Eigen::Isometry3d camera_from_world = model_->base_world_from_camera.inverse();
  const Eigen::Vector3d top_cam = camera_from_world * Eigen::Vector3d(c.x(), c.y(), height);
  if (top_cam.z() < 0.6) return std::nullopt;
  const CameraIntrinsics& k = params_.intrinsics;
  const Eigen::Vector2d px = k.project(top_cam);
  if (px.x() < 20 || px.y() < 20 || px.x() > k.width - 20 || px.y() > k.height - 20)
    return std::nullopt;
  return c;
}

bool LayoutBuilder::isFree(const std::vector<Footprint>& taken, const Eigen::Vector2d& c,
                           double radius) {
  constexpr double kGap = 0.01;
  return std::all_of(taken.begin(), taken.end(), [&](const Footprint& f) {
    return (f.center - c).norm() >= f.radius + radius + kGap;
  });
}

}  // namespace shapesense::synthetic::detail
