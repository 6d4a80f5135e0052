// Shelf units standing against a wall: two side panels, 2-4 boards, sometimes a back panel, and
// a box on some of the boards. Runs inside withExtraStream (see layout_extras.cpp).

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

namespace {

/// Whether two floor rectangles, each grown by `margin`, overlap (separating axes).
bool blocksOverlap(const FloorBlock& a, const FloorBlock& b, double margin) {
  const std::array<const FloorBlock*, 2> both = {&a, &b};
  for (const FloorBlock* axis_owner : both) {
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector2d axis = Eigen::Rotation2Dd(axis_owner->yaw) *
                                   (k == 0 ? Eigen::Vector2d::UnitX() : Eigen::Vector2d::UnitY());
      double reach = 0.0;
      for (const FloorBlock* r : both) {
        const Eigen::Matrix2d rot = Eigen::Rotation2Dd(r->yaw).toRotationMatrix();
        reach += std::abs(axis.dot(rot.col(0))) * r->half.x() +
                 std::abs(axis.dot(rot.col(1))) * r->half.y() + margin;
      }
      if (std::abs(axis.dot(a.center - b.center)) >= reach) return false;
    }
  }
  return true;
}

}  // namespace

void LayoutBuilder::addShelf() {
  const double width = rng_.uniform(0.6, 1.2);
  const double depth = rng_.uniform(0.25, 0.4);
  const double height = std::min(rng_.uniform(0.8, 2.0), room_height_ - 0.05);
  const double panel = rng_.uniform(0.015, 0.025);
  const int boards = rng_.uniformInt(2, 4);
  const bool back_panel = rng_.chance(0.5);
  const Eigen::Vector3f colour =
      rng_.chance(0.5) ? jitterColour(rng_, Eigen::Vector3f(60, 100, 150), 0.15)    // wood
                       : jitterColour(rng_, Eigen::Vector3f(215, 215, 210), 0.05);  // white

  // A stretch of the back, left or right wall, clear of the table, the floor objects and the
  // camera; in view if possible.
  FloorBlock block{Eigen::Vector2d::Zero(), 0.0, Eigen::Vector2d(width / 2, depth / 2)};
  bool placed = false;
  for (int attempt = 0; attempt < 120 && !placed; ++attempt) {
    const int wall = rng_.uniformInt(0, 2);
    const double gap = rng_.uniform(0.005, 0.03);
    const double inset = depth / 2 + gap;
    if (wall == 0) {  // back: front (local -y) towards -y
      const double lo = room_min_.x() + width / 2 + 0.02, hi = room_max_.x() - width / 2 - 0.02;
      if (hi <= lo) continue;
      block.center = {rng_.uniform(lo, hi), room_max_.y() - inset};
      block.yaw = 0.0;
    } else {
      const double lo = room_min_.y() + width / 2 + 0.02, hi = room_max_.y() - width / 2 - 0.02;
      if (hi <= lo) continue;
      const double along = rng_.uniform(lo, hi);
      block.center = wall == 1 ? Eigen::Vector2d(room_min_.x() + inset, along)
                               : Eigen::Vector2d(room_max_.x() - inset, along);
      block.yaw = wall == 1 ? std::numbers::pi / 2 : -std::numbers::pi / 2;
    }
    if (!clearOfBlocks(block.center, 0.0)) continue;
    bool clear = std::none_of(floor_blocks_.begin(), floor_blocks_.end(),
                              [&](const FloorBlock& b) { return blocksOverlap(block, b, 0.02); });
    const FloorBlock camera_block{camera_position_.head<2>(), 0.0, Eigen::Vector2d(0.3, 0.3)};
    clear = clear && !blocksOverlap(block, camera_block, 0.0);
    for (const Footprint& f : floor_footprints_) {
      const Eigen::Vector2d local = Eigen::Rotation2Dd(-block.yaw) * (f.center - block.center);
      clear = clear && (local.cwiseAbs() - block.half).cwiseMax(0.0).norm() >= f.radius + 0.01;
    }
    if (!clear) continue;
    const Eigen::Vector2d front =
        block.center + Eigen::Rotation2Dd(block.yaw) * Eigen::Vector2d(0.0, -depth / 2);
    if (attempt < 80 && !inView({front.x(), front.y(), height / 2}, 0.0)) continue;
    placed = true;
  }
  if (!placed) return;
  floor_blocks_.push_back(block);

  ObjectDef shelf;
  shelf.kind = "shelf";
  shelf.name = nextObjectName("shelf");
  shelf.world_from_object = poseAt({block.center.x(), block.center.y(), 0.0}, block.yaw);
  shelf.local_box = Eigen::AlignedBox3d(Eigen::Vector3d(-width / 2, -depth / 2, 0.0),
                                        Eigen::Vector3d(width / 2, depth / 2, height));
  const std::uint16_t id = addObject(shelf);
  const Eigen::Isometry3d& pose = shelf.world_from_object;
  for (int side = 0; side < 2; ++side) {
    const double x = (side == 0 ? -1.0 : 1.0) * (width / 2 - panel / 2);
    addBoxSolid(pose * poseAt({x, 0.0, height / 2}, 0.0), {panel / 2, depth / 2, height / 2}, id,
                shelf.name + "_side" + std::to_string(side + 1), colour);
  }
  const double inner_half_width = width / 2 - panel;
  const double back = back_panel ? panel : 0.0;
  if (back_panel)
    addBoxSolid(pose * poseAt({0.0, depth / 2 - panel / 2, height / 2}, 0.0),
                {inner_half_width, panel / 2, height / 2}, id, shelf.name + "_back",
                colour * 0.92f);
  // Boards from just above the floor to the top, evenly spaced (board centres).
  const double lowest = rng_.uniform(0.05, 0.15);
  const double top = height - panel / 2;
  const double spacing = (top - lowest) / (boards - 1);
  const Eigen::Vector2d board_half(inner_half_width, (depth - back) / 2);
  for (int j = 0; j < boards; ++j) {
    const double z = lowest + j * spacing;
    const Eigen::Isometry3d board_pose = pose * poseAt({0.0, -back / 2, z}, 0.0);
    addBoxSolid(board_pose, {board_half.x(), board_half.y(), panel / 2}, id,
                shelf.name + "_board" + std::to_string(j + 1), colour);
    // Half the boards below the top one hold a box.
    const double clearance = spacing - panel;
    if (j + 1 == boards || clearance < 0.12 || !rng_.chance(0.5)) continue;
    Support board{board_pose * poseAt({0.0, 0.0, panel / 2}, 0.0), board_half, clearance, {}};
    const double max_side = std::min(0.3, 2.0 * board_half.minCoeff() - 0.02);
    if (max_side < 0.06) continue;
    const Eigen::Vector3d size =
        rng_.uniform3({0.06, 0.06, 0.05}, {max_side, max_side, std::min(0.35, clearance - 0.03)});
    const auto spot = supportSpot(board, 0.5 * std::hypot(size.x(), size.y()), size.z());
    if (spot) addSupportingBox(*spot, size, clearance - size.z());
  }
}

}  // namespace shapesense::synthetic::detail
