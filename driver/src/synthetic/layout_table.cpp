// The table: a top slab on four legs, all wooden.

#include <array>
#include <string>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

void LayoutBuilder::addTable() {
  const double top_thickness = rng_.uniform(0.025, 0.045);
  const double leg = rng_.uniform(0.04, 0.07);
  const double inset = rng_.uniform(0.03, 0.1);
  const Eigen::Vector3f wood = rng_.uniform3({40, 70, 110}, {90, 120, 170}).cast<float>();

  ObjectDef table;
  table.kind = "table";
  table.name = "table";
  table.world_from_object = poseAt({table_center_.x(), table_center_.y(), 0.0}, table_yaw_);
  table.local_box =
      Eigen::AlignedBox3d(Eigen::Vector3d(-table_size_.x() / 2, -table_size_.y() / 2, 0.0),
                          Eigen::Vector3d(table_size_.x() / 2, table_size_.y() / 2, table_height_));
  const std::uint16_t id = addObject(table);

  addBoxSolid(table.world_from_object * poseAt({0.0, 0.0, table_height_ - top_thickness / 2}, 0.0),
              {table_size_.x() / 2, table_size_.y() / 2, top_thickness / 2}, id, table.name, wood,
              {"_edge_left", "_edge_right", "_edge_front", "_edge_back", "_underside", "_top"});
  const double leg_height = table_height_ - top_thickness;
  const double lx = table_size_.x() / 2 - inset - leg / 2;
  const double ly = table_size_.y() / 2 - inset - leg / 2;
  const std::array<Eigen::Vector2d, 4> corners = {Eigen::Vector2d(-lx, -ly),
                                                  Eigen::Vector2d(lx, -ly), Eigen::Vector2d(lx, ly),
                                                  Eigen::Vector2d(-lx, ly)};
  for (int k = 0; k < 4; ++k) {
    addBoxSolid(
        table.world_from_object * poseAt({corners[k].x(), corners[k].y(), leg_height / 2}, 0.0),
        {leg / 2, leg / 2, leg_height / 2}, id, table.name + "_leg" + std::to_string(k + 1),
        wood * 0.85f);
  }
}

}  // namespace shapesense::synthetic::detail
