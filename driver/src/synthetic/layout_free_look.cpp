// Free look (SceneParams::free_look): the camera anywhere beside the table at any height,
// looking towards a random point of the table area with a drawn pitch, in a room drawn by size.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

void LayoutBuilder::placeFreeLookCamera() {
  const SceneParams& p = params_;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const double camera_height = rng_.uniform(p.free_look_height_min_m, p.free_look_height_max_m);
    table_height_ = rng_.uniform(0.62, 0.78);
    table_size_ = {rng_.uniform(0.8, 1.6), rng_.uniform(0.6, 1.0)};
    const double distance =
        rng_.uniform(p.free_look_table_distance_min_m, p.free_look_table_distance_max_m);
    const double azimuth = degToRad(rng_.uniform(-30.0, 30.0));
    table_center_ = {distance * std::sin(azimuth), distance * std::cos(azimuth)};
    table_yaw_ = rng_.uniform(-std::numbers::pi, std::numbers::pi);
    const double spread = p.free_look_target_spread_m;
    const Eigen::Vector2d target_local =
        rng_.uniform2({-1.0, -1.0}, {1.0, 1.0})
            .cwiseProduct(table_size_ / 2 + Eigen::Vector2d::Constant(spread));
    const double pitch =
        degToRad(rng_.uniform(p.free_look_pitch_min_deg, p.free_look_pitch_max_deg));
    const double roll = degToRad(rng_.uniform(-1.0, 1.0));
    // The robot stands beside the table, not over or under it.
    const Eigen::Vector2d camera_in_table =
        Eigen::Rotation2Dd(-table_yaw_) * (Eigen::Vector2d::Zero() - table_center_);
    const Eigen::Vector2d outside = (camera_in_table.cwiseAbs() - table_size_ / 2.0).cwiseMax(0.0);
    if (outside.norm() < 0.25) continue;
    const Eigen::Vector2d target = table_center_ + Eigen::Rotation2Dd(table_yaw_) * target_local;
    if (target.norm() < 0.3) continue;  // the azimuth of a point at the feet is ill-defined
    camera_position_ = {0.0, 0.0, camera_height};
    const Eigen::Vector2d heading = target.normalized();
    const Eigen::Vector3d forward(heading.x() * std::cos(pitch), heading.y() * std::cos(pitch),
                                  -std::sin(pitch));
    model_->base_world_from_camera = lookAt(camera_position_, camera_position_ + forward, roll);
    return;
  }
  throw std::invalid_argument("SceneParams: no free-look camera pose beside the table");
}

void LayoutBuilder::drawRoomSize(Eigen::Vector3d& half, Eigen::Isometry3d& world_from_room) {
  const SceneParams& p = params_;
  // What must fit: the camera and the table, each with 0.3 m around.
  const double c = std::abs(std::cos(table_yaw_)), s = std::abs(std::sin(table_yaw_));
  const Eigen::Vector2d table_reach(c * table_size_.x() / 2 + s * table_size_.y() / 2,
                                    s * table_size_.x() / 2 + c * table_size_.y() / 2);
  const Eigen::Vector2d margin = Eigen::Vector2d::Constant(0.3);
  const Eigen::Vector2d lo =
      (table_center_ - table_reach).cwiseMin(Eigen::Vector2d::Zero()) - margin;
  const Eigen::Vector2d hi =
      (table_center_ + table_reach).cwiseMax(Eigen::Vector2d::Zero()) + margin;
  Eigen::Vector2d size = rng_.uniform2(Eigen::Vector2d::Constant(p.room_extent_min_m),
                                       Eigen::Vector2d::Constant(p.room_extent_max_m));
  size = size.cwiseMax(hi - lo);
  const Eigen::Vector2d slack = size - (hi - lo);
  room_min_ = lo - rng_.uniform2(Eigen::Vector2d::Zero(), slack);
  room_max_ = room_min_ + size;
  const double height =
      std::max(rng_.uniform(p.room_height_min_m, p.room_height_max_m), camera_position_.z() + 0.3);
  half = Eigen::Vector3d(size.x() / 2, size.y() / 2, height / 2);
  const Eigen::Vector2d centre = (room_min_ + room_max_) / 2;
  world_from_room = poseAt({centre.x(), centre.y(), height / 2}, 0.0);
}

}  // namespace shapesense::synthetic::detail
