// The camera, the table's place in front of it, and the room around both.

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

void LayoutBuilder::placeCameraAndTable() {
  const double min_elevation = degToRad(params_.min_table_elevation_deg);
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const double camera_height =
        rng_.uniform(params_.camera_height_min_m, params_.camera_height_max_m);
    table_height_ = rng_.uniform(0.62, 0.78);
    table_size_ = {rng_.uniform(0.8, 1.6), rng_.uniform(0.6, 1.0)};
    const double rise = camera_height - table_height_;
    if (rise <= 0.05) continue;
    const double max_distance =
        std::min(params_.table_distance_max_m, rise / std::sin(min_elevation));
    if (max_distance < params_.table_distance_min_m) continue;
    const double distance = rng_.uniform(params_.table_distance_min_m, max_distance);
    // A camera higher above the table top than its distance to it cannot exist (never the
    // case with the default ranges, whose draws this keeps).
    if (distance <= rise) continue;
    const double horizontal = std::sqrt(distance * distance - rise * rise);
    const double azimuth = degToRad(rng_.uniform(-10.0, 10.0));
    table_center_ = {horizontal * std::sin(azimuth), horizontal * std::cos(azimuth)};
    table_yaw_ = -azimuth + degToRad(rng_.uniform(-25.0, 25.0));
    // The robot stands beside the table, not over it.
    const Eigen::Vector2d camera_in_table =
        Eigen::Rotation2Dd(-table_yaw_) * (Eigen::Vector2d::Zero() - table_center_);
    const Eigen::Vector2d outside = (camera_in_table.cwiseAbs() - table_size_ / 2.0).cwiseMax(0.0);
    if (outside.norm() < 0.15) continue;
    camera_position_ = {0.0, 0.0, camera_height};
    const Eigen::Vector2d aim = table_center_ + rng_.uniform2({-0.1, -0.1}, {0.1, 0.1});
    const Eigen::Vector3d target(aim.x(), aim.y(), table_height_);
    model_->base_world_from_camera =
        lookAt(camera_position_, target, degToRad(rng_.uniform(-1.0, 1.0)));
    return;
  }
  throw std::invalid_argument(
      "SceneParams: no camera height / table distance satisfies min_table_elevation_deg");
}

void LayoutBuilder::addRoom() {
  Eigen::Vector3d half;
  Eigen::Isometry3d world_from_room;
  if (params_.free_look) {
    drawRoomSize(half, world_from_room);
  } else {
    drawRoomExtent(half, world_from_room);
  }
  room_height_ = 2.0 * half.z();
  const Eigen::Vector3f floor_colour = rng_.uniform3({90, 110, 120}, {150, 160, 170}).cast<float>();
  const Eigen::Vector3f wall_colour = rng_.uniform3({170, 180, 185}, {230, 235, 240}).cast<float>();
  addSolid(
      std::make_unique<RoomSolid>(half), world_from_room, 0, "", [&](int face, const FaceLabel&) {
        return face == RoomSolid::kFloor ? floor_colour : jitterColour(rng_, wall_colour, 0.08);
      });
}

void LayoutBuilder::drawRoomExtent(Eigen::Vector3d& half, Eigen::Isometry3d& world_from_room) {
  // Walls close around the table; a layout is redrawn until two or three walls are in view
  // (ignoring occlusion by the table), with the gaps allowed to grow on later tries.
  const double c = std::abs(std::cos(table_yaw_)), s = std::abs(std::sin(table_yaw_));
  const Eigen::Vector2d table_reach(c * table_size_.x() / 2 + s * table_size_.y() / 2,
                                    s * table_size_.x() / 2 + c * table_size_.y() / 2);
  for (int attempt = 0;; ++attempt) {
    const double spread = 1.0 + 0.1 * attempt;
    const double left =
        std::min(table_center_.x() - table_reach.x(), -0.3) - rng_.uniform(0.05, 0.9);
    const double right =
        std::max(table_center_.x() + table_reach.x(), 0.3) + rng_.uniform(0.05, 1.5);
    const double back = table_center_.y() + table_reach.y() + rng_.uniform(0.1, 0.9 * spread);
    const double front = -rng_.uniform(0.8, 1.5);
    const double ceiling = rng_.uniform(2.4, 2.8);
    room_min_ = {left, front};
    room_max_ = {right, back};
    half = Eigen::Vector3d(0.5 * (right - left), 0.5 * (back - front), 0.5 * ceiling);
    world_from_room = poseAt({0.5 * (left + right), 0.5 * (front + back), 0.5 * ceiling}, 0.0);
    if (visibleWalls(RoomSolid(half), world_from_room) >= 2 || attempt >= 50) return;
  }
}

/// How many of the left, right and back walls a coarse grid of camera rays sees in range.
int LayoutBuilder::visibleWalls(const RoomSolid& room,
                                const Eigen::Isometry3d& world_from_room) const {
  const CameraIntrinsics& k = params_.intrinsics;
  const Eigen::Isometry3d room_from_camera =
      world_from_room.inverse() * model_->base_world_from_camera;
  std::array<int, 6> rays_per_face{};
  constexpr int kGrid = 24;
  for (int gy = 0; gy < kGrid; ++gy)
    for (int gx = 0; gx < kGrid; ++gx) {
      const double u = (gx + 0.5) * k.width / kGrid, v = (gy + 0.5) * k.height / kGrid;
      LocalHit hit;
      if (room.intersect(room_from_camera.translation(), room_from_camera.linear() * k.ray(u, v),
                         hit) &&
          hit.t < params_.kinect.max_range_m - 0.1)
        ++rays_per_face[static_cast<std::size_t>(hit.face)];
    }
  constexpr int kMinRays = 4;  // ~1% of the image each
  return (rays_per_face[RoomSolid::kWallLeft] >= kMinRays) +
         (rays_per_face[RoomSolid::kWallRight] >= kMinRays) +
         (rays_per_face[RoomSolid::kWallBack] >= kMinRays);
}

}  // namespace shapesense::synthetic::detail
