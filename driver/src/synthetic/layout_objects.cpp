// The objects on the table (and the occasional box on the floor). Each step draws the object's
// dimensions, finds it a free spot, records it and adds its solid; a step that finds no spot
// adds nothing.

#include <cmath>
#include <numbers>
#include <string>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

void LayoutBuilder::addTableBox() {
  const Eigen::Vector3d size = rng_.uniform3({0.06, 0.06, 0.05}, {0.32, 0.32, 0.3});
  const auto spot = tableSpot(0.5 * std::hypot(size.x(), size.y()));
  if (!spot) return;
  addBox(*spot, size);
}

void LayoutBuilder::addFloorBox() {
  const Eigen::Vector3d size = rng_.uniform3({0.2, 0.2, 0.15}, {0.45, 0.45, 0.45});
  const auto spot = floorSpot(0.5 * std::hypot(size.x(), size.y()), size.z());
  if (!spot) return;
  addBox(*spot, size);
}

/// `support` is a pose on the supporting surface (z up) where the box's bottom centre goes.
void LayoutBuilder::addBox(const Eigen::Isometry3d& support, const Eigen::Vector3d& size) {
  const bool cardboard = rng_.chance(0.5);
  const Eigen::Vector3f colour =
      cardboard ? jitterColour(rng_, Eigen::Vector3f(70, 130, 175), 0.12) : objectColour();
  ObjectDef box;
  box.kind = "box";
  box.name = nextObjectName("box");
  box.world_from_object = support * poseAt({0.0, 0.0, size.z() / 2}, 0.0);
  box.local_box = Eigen::AlignedBox3d(-size / 2, size / 2);
  const std::uint16_t id = addObject(box);
  addBoxSolid(box.world_from_object, size / 2, id, box.name, colour);
  // Its top, for the stacked boxes and thin objects of the wider distribution (draws nothing).
  box_tops_.push_back(
      {box.world_from_object * poseAt({0.0, 0.0, size.z() / 2}, 0.0), size.head<2>() / 2, 1e9, {}});
}

void LayoutBuilder::addBowl() {
  const double rim_radius = rng_.uniform(0.06, 0.15);
  const double shallowness = rng_.uniform(0.0, 0.45);  // 0 = hemisphere
  const double radius = rim_radius / std::sqrt(1.0 - shallowness * shallowness);
  const double rim_z = -shallowness * radius;
  const double thickness = rng_.uniform(0.004, 0.01);
  const bool upright = !rng_.chance(params_.bowl_upside_down_probability);
  const auto spot = tableSpot(rim_radius);
  if (!spot) return;

  ObjectDef bowl;
  bowl.kind = "bowl";
  bowl.name = nextObjectName("bowl");
  bowl.bowl = BowlDef{upright, rim_z, rim_radius, radius + rim_z, thickness};
  // Upright it rests on the lowest point of its outer sphere, upside down on its rim.
  if (upright) {
    bowl.world_from_object = *spot * poseAt({0.0, 0.0, radius}, 0.0);
  } else {
    Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
    flip.translation() = Eigen::Vector3d(0.0, 0.0, -rim_z);
    flip.linear() =
        Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix();
    bowl.world_from_object = *spot * flip;
  }
  auto solid = std::make_unique<BowlSolid>(radius, rim_z, thickness);
  addSolidObject(std::move(bowl), std::move(solid), objectColour());
}

void LayoutBuilder::addCup() {
  const double radius = rng_.uniform(0.035, 0.05);
  const double height = rng_.uniform(0.08, 0.12);
  const double wall = rng_.uniform(0.003, 0.005);
  const double bottom = rng_.uniform(0.005, 0.01);
  const auto spot = tableSpot(radius);
  if (!spot) return;
  ObjectDef cup;
  cup.kind = "cup";
  cup.name = nextObjectName("cup");
  cup.world_from_object = *spot;
  auto solid = std::make_unique<CupSolid>(radius, height, wall, bottom);
  addSolidObject(std::move(cup), std::move(solid), objectColour());
}

void LayoutBuilder::addTin() {
  const double radius = rng_.uniform(0.03, 0.06);
  const double height = rng_.uniform(0.06, 0.2);
  const auto spot = tableSpot(radius);
  if (!spot) return;
  ObjectDef tin;
  tin.kind = "tin";
  tin.name = nextObjectName("tin");
  tin.world_from_object = *spot;
  auto solid = std::make_unique<TinSolid>(radius, height);
  // Half the tins are bare metal.
  const Eigen::Vector3f colour =
      rng_.chance(0.5) ? jitterColour(rng_, {175, 175, 180}, 0.1) : objectColour();
  addSolidObject(std::move(tin), std::move(solid), colour);
}

void LayoutBuilder::addBall() {
  const double radius = rng_.uniform(0.03, 0.11);
  const auto spot = tableSpot(radius);
  if (!spot) return;
  ObjectDef ball;
  ball.kind = "ball";
  ball.name = nextObjectName("ball");
  ball.world_from_object = *spot * poseAt({0.0, 0.0, radius}, 0.0);
  auto solid = std::make_unique<BallSolid>(radius);
  addSolidObject(std::move(ball), std::move(solid), objectColour());
}

}  // namespace shapesense::synthetic::detail
