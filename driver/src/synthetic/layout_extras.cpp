// The wider distribution's additions (issue #18): the extra camera roll, more boxes (3-60 cm),
// stacked and touching boxes, thin objects (books, boards, lids), lying tins, bins and
// columns. Every step here runs inside withExtraStream, so rng_ is the extra stream and the
// scene's main draws stay what they were.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

bool LayoutBuilder::anyExtras() const {
  const SceneParams& p = params_;
  return p.extra_boxes_max > 0 || p.stacked_boxes_max > 0 || p.touching_box_pairs_max > 0 ||
         p.thin_objects_max > 0 || p.shelves_max > 0 || p.lying_tins_max > 0 || p.bins_max > 0 ||
         p.columns_max > 0 || p.tori_max > 0 || p.mounds_max > 0;
}

void LayoutBuilder::addExtras() {
  const SceneParams& p = params_;
  floor_blocks_.push_back(
      {table_center_, table_yaw_, table_size_ / 2 + Eigen::Vector2d::Constant(0.05)});
  addSeveral(p.shelves_min, p.shelves_max, &LayoutBuilder::addShelf);
  addSeveral(p.columns_min, p.columns_max, &LayoutBuilder::addColumn);
  addSeveral(p.bins_min, p.bins_max, &LayoutBuilder::addBin);
  addSeveral(p.extra_boxes_min, p.extra_boxes_max, &LayoutBuilder::addExtraBox);
  addSeveral(p.touching_box_pairs_min, p.touching_box_pairs_max,
             &LayoutBuilder::addTouchingBoxPair);
  addSeveral(p.stacked_boxes_min, p.stacked_boxes_max, &LayoutBuilder::addStackedBox);
  addSeveral(p.thin_objects_min, p.thin_objects_max, &LayoutBuilder::addThinObject);
  addSeveral(p.lying_tins_min, p.lying_tins_max, &LayoutBuilder::addLyingTin);
  addSeveral(p.tori_min, p.tori_max, &LayoutBuilder::addTorus);
  addSeveral(p.mounds_min, p.mounds_max, &LayoutBuilder::addMound);
}

void LayoutBuilder::addCameraRoll() {
  const double roll =
      degToRad(rng_.uniform(-params_.camera_roll_max_deg, params_.camera_roll_max_deg));
  Eigen::Isometry3d& pose = model_->base_world_from_camera;
  pose.linear() =
      pose.linear() * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void LayoutBuilder::addExtraBox() {
  const double lo = params_.extra_box_size_min_m, hi = params_.extra_box_size_max_m;
  const auto side = [&] { return lo * std::pow(hi / lo, rng_.uniform()); };
  const Eigen::Vector3d size(side(), side(), side());
  const double radius = 0.5 * std::hypot(size.x(), size.y());
  if (rng_.chance(0.6)) {
    if (const auto spot = tableSpot(radius)) return addBox(*spot, size);
  }
  if (const auto spot = openFloorSpot(radius, size.z())) addBox(*spot, size);
}

void LayoutBuilder::addTouchingBoxPair() {
  const Eigen::Vector3d a = rng_.uniform3({0.06, 0.06, 0.04}, {0.35, 0.35, 0.35});
  Eigen::Vector3d b = rng_.uniform3({0.06, 0.06, 0.04}, {0.35, 0.35, 0.35});
  const int heights = rng_.uniformInt(0, 2);
  if (heights == 0) b.z() = a.z();                             // one top plane
  if (heights == 1) b.z() = a.z() + rng_.uniform(0.01, 0.03);  // tops 1-3 cm apart
  const bool flush_fronts = rng_.chance(0.5);
  const double gap = rng_.uniform(0.0, 0.01);
  const double width = a.x() + gap + b.x(), depth = std::max(a.y(), b.y());
  const double radius = 0.5 * std::hypot(width, depth);
  auto spot = tableSpot(radius);
  if (!spot) spot = openFloorSpot(radius, std::max(a.z(), b.z()));
  if (!spot) return;
  const double ya = flush_fronts ? (a.y() - depth) / 2 : 0.0;
  const double yb = flush_fronts ? (b.y() - depth) / 2 : 0.0;
  // Both in one order so that which is left is random through the spot's yaw.
  addBox(*spot * poseAt({(a.x() - width) / 2, ya, 0.0}, 0.0), a);
  addBox(*spot * poseAt({(width - b.x()) / 2, yb, 0.0}, 0.0), b);
}

void LayoutBuilder::addStackedBox() {
  // A few tries: a drawn top can be too small or too full.
  for (int attempt = 0; attempt < 5 && !box_tops_.empty(); ++attempt) {
    const std::size_t k =
        static_cast<std::size_t>(rng_.uniformInt(0, static_cast<int>(box_tops_.size()) - 1));
    // The footprint circle must fit: sides up to sqrt(2) * (half the shorter side).
    const double max_side = std::min(0.3, std::sqrt(2.0) * (box_tops_[k].half.minCoeff() - 0.01));
    if (max_side < 0.04) continue;
    const Eigen::Vector3d size = rng_.uniform3({0.04, 0.04, 0.03}, {max_side, max_side, 0.3});
    const auto spot = supportSpot(box_tops_[k], 0.5 * std::hypot(size.x(), size.y()), size.z());
    if (!spot) continue;
    addSupportingBox(*spot, size, box_tops_[k].clearance - size.z());
    return;
  }
}

std::uint16_t LayoutBuilder::addSupportingBox(const Eigen::Isometry3d& support,
                                              const Eigen::Vector3d& size, double clearance) {
  addBox(support, size);
  box_tops_.back().clearance = clearance;
  return static_cast<std::uint16_t>(model_->objects.size());
}

void LayoutBuilder::addThinObject() {
  const int type = rng_.uniformInt(0, params_.thin_object_lids ? 2 : 1);  // book, board, lid
  Eigen::Vector3d size;
  if (type == 0) {
    size = {rng_.uniform(0.12, 0.3), rng_.uniform(0.1, 0.22), rng_.uniform(0.015, 0.03)};
  } else if (type == 1) {
    size = {rng_.uniform(0.2, 0.45), rng_.uniform(0.15, 0.3), rng_.uniform(0.01, 0.025)};
  } else {
    const double r = rng_.uniform(0.05, 0.12);
    size = {2.0 * r, 2.0 * r, rng_.uniform(0.01, 0.02)};
  }
  const bool on_box = !box_tops_.empty() && rng_.chance(0.5);
  std::optional<Eigen::Isometry3d> spot;
  // A crowded table or a small box top: try smaller (same thickness) before giving up.
  for (int attempt = 0; attempt < 3 && !spot; ++attempt) {
    if (attempt > 0) size.head<2>() *= 0.75;
    const double radius = type == 2 ? size.x() / 2 : 0.5 * std::hypot(size.x(), size.y());
    if (on_box) {
      const std::size_t k =
          static_cast<std::size_t>(rng_.uniformInt(0, static_cast<int>(box_tops_.size()) - 1));
      spot = supportSpot(box_tops_[k], radius, size.z());
    }
    if (!spot) spot = tableSpot(radius);
  }
  if (!spot) return;

  ObjectDef thin;
  const Eigen::Vector3f colour = objectColour();
  if (type == 2) {
    thin.kind = "lid";
    thin.name = nextObjectName("lid");
    thin.world_from_object = *spot;
    auto solid = std::make_unique<TinSolid>(size.x() / 2, size.z());
    addSolidObject(std::move(thin), std::move(solid), colour);
    return;
  }
  thin.kind = type == 0 ? "book" : "board";
  thin.name = nextObjectName(thin.kind);
  thin.world_from_object = *spot * poseAt({0.0, 0.0, size.z() / 2}, 0.0);
  thin.local_box = Eigen::AlignedBox3d(-size / 2, size / 2);
  const std::uint16_t id = addObject(thin);
  addBoxSolid(thin.world_from_object, size / 2, id, thin.name, colour);
  // Books and boards hold things too (a book on a book: two planes 1-3 cm apart).
  box_tops_.push_back({thin.world_from_object * poseAt({0.0, 0.0, size.z() / 2}, 0.0),
                       size.head<2>() / 2,
                       1e9,
                       {}});
}

void LayoutBuilder::addLyingTin() {
  const double radius = rng_.uniform(0.03, 0.06);
  const double length = rng_.uniform(0.08, 0.2);
  const auto spot = tableSpot(0.5 * std::hypot(length, 2.0 * radius));
  if (!spot) return;
  ObjectDef tin;
  tin.kind = "tin";
  tin.name = nextObjectName("tin");
  // The tin's axis (its local z, from the bottom) along the spot's x, resting on its side.
  Eigen::Isometry3d lying = Eigen::Isometry3d::Identity();
  lying.translation() = Eigen::Vector3d(-length / 2, 0.0, radius);
  lying.linear() =
      Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  tin.world_from_object = *spot * lying;
  auto solid = std::make_unique<TinSolid>(radius, length);
  // Half the tins are bare metal.
  const Eigen::Vector3f colour =
      rng_.chance(0.5) ? jitterColour(rng_, {175, 175, 180}, 0.1) : objectColour();
  addSolidObject(std::move(tin), std::move(solid), colour);
}

void LayoutBuilder::addBin() {
  const double radius = rng_.uniform(0.12, 0.25);
  const double height = rng_.uniform(0.3, 0.7);
  const double wall = rng_.uniform(0.005, 0.01);
  const double bottom = rng_.uniform(0.01, 0.02);
  const auto spot = openFloorSpot(radius, height);
  if (!spot) return;
  ObjectDef bin;
  bin.kind = "bin";
  bin.name = nextObjectName("bin");
  bin.world_from_object = *spot;
  auto solid = std::make_unique<CupSolid>(radius, height, wall, bottom);
  addSolidObject(std::move(bin), std::move(solid), objectColour());
}

void LayoutBuilder::addColumn() {
  const double radius = rng_.uniform(0.1, 0.25);
  const auto spot = openFloorSpot(radius, 1.0);
  if (!spot) return;
  ObjectDef column;
  column.kind = "column";
  column.name = nextObjectName("column");
  column.world_from_object = *spot;
  auto solid = std::make_unique<TinSolid>(radius, room_height_);
  addSolidObject(std::move(column), std::move(solid),
                 jitterColour(rng_, Eigen::Vector3f(200, 205, 210), 0.1));
}

void LayoutBuilder::addTorus() {
  const double major = rng_.uniform(0.04, 0.12);
  const double tube = rng_.uniform(0.01, std::min(0.03, 0.6 * major));
  const auto spot = tableSpot(major + tube);
  if (!spot) return;
  ObjectDef torus;
  torus.kind = "torus";
  torus.name = nextObjectName("torus");
  torus.world_from_object = *spot * poseAt({0.0, 0.0, tube}, 0.0);
  auto solid = std::make_unique<TorusSolid>(major, tube);
  addSolidObject(std::move(torus), std::move(solid), objectColour());
}

void LayoutBuilder::addMound() {
  Eigen::Vector2d half = rng_.uniform2({0.1, 0.1}, {0.25, 0.25});
  const double height = rng_.uniform(0.03, 0.12);
  std::vector<MoundSolid::Bump> bumps(static_cast<std::size_t>(rng_.uniformInt(1, 3)));
  for (MoundSolid::Bump& b : bumps)
    b = {{rng_.uniform(-0.5, 0.5), rng_.uniform(-0.5, 0.5)},
         rng_.uniform(0.25, 0.6),
         rng_.uniform(0.5, 1.0)};
  std::optional<Eigen::Isometry3d> spot;
  for (int attempt = 0; attempt < 3 && !spot; ++attempt) {
    if (attempt > 0) half *= 0.75;
    spot = tableSpot(half.norm());
  }
  if (!spot) return;
  ObjectDef mound;
  mound.kind = "mound";
  mound.name = nextObjectName("mound");
  mound.world_from_object = *spot;
  // The bumps' weights are relative: scale them so that the highest point is `height`.
  const double peak = MoundSolid(half, 1.0, bumps).peakHeight();
  for (MoundSolid::Bump& b : bumps) b.weight *= height / peak;
  auto solid = std::make_unique<MoundSolid>(half, 1.0, std::move(bumps));
  // Tight (the solid's bounds keep a margin above the peak).
  mound.local_box = Eigen::AlignedBox3d(Eigen::Vector3d(-half.x(), -half.y(), 0.0),
                                        Eigen::Vector3d(half.x(), half.y(), solid->peakHeight()));
  const std::uint16_t id = addObject(mound);
  addShadedSolid(std::move(solid), mound, id, objectColour());
}

std::optional<Eigen::Isometry3d> LayoutBuilder::supportSpot(Support& support, double radius,
                                                            double height) {
  if (height > support.clearance - 0.01) return std::nullopt;
  const Eigen::Vector2d reach = support.half - Eigen::Vector2d::Constant(radius + 0.005);
  if (reach.minCoeff() < 0.0) return std::nullopt;
  for (int attempt = 0; attempt < 50; ++attempt) {
    const Eigen::Vector2d c = rng_.uniform2(-reach, reach);
    if (!isFree(support.taken, c, radius)) continue;
    support.taken.push_back({c, radius});
    return support.top *
           poseAt({c.x(), c.y(), 0.0}, rng_.uniform(-std::numbers::pi, std::numbers::pi));
  }
  return std::nullopt;
}

std::optional<Eigen::Isometry3d> LayoutBuilder::openFloorSpot(double radius, double height) {
  const Eigen::Vector2d lo = room_min_ + Eigen::Vector2d::Constant(radius + 0.02);
  const Eigen::Vector2d hi = room_max_ - Eigen::Vector2d::Constant(radius + 0.02);
  if ((hi - lo).minCoeff() <= 0.0) return std::nullopt;
  for (int attempt = 0; attempt < 200; ++attempt) {
    const Eigen::Vector2d c = rng_.uniform2(lo, hi);
    if ((c - camera_position_.head<2>()).norm() < radius + 0.45) continue;
    if (!isFree(floor_footprints_, c, radius) || !clearOfBlocks(c, radius)) continue;
    if (!inView({c.x(), c.y(), height}, 20.0) && !inView({c.x(), c.y(), 0.0}, 20.0)) continue;
    floor_footprints_.push_back({c, radius});
    return poseAt({c.x(), c.y(), 0.0}, rng_.uniform(-std::numbers::pi, std::numbers::pi));
  }
  return std::nullopt;
}

bool LayoutBuilder::clearOfBlocks(const Eigen::Vector2d& c, double radius) const {
  return std::all_of(floor_blocks_.begin(), floor_blocks_.end(), [&](const FloorBlock& b) {
    const Eigen::Vector2d local = Eigen::Rotation2Dd(-b.yaw) * (c - b.center);
    return (local.cwiseAbs() - b.half).cwiseMax(0.0).norm() >= radius + 0.01;
  });
}

bool LayoutBuilder::inView(const Eigen::Vector3d& world_point, double margin_px) const {
  const Eigen::Vector3d p = model_->base_world_from_camera.inverse() * world_point;
  if (p.z() < params_.kinect.min_range_m + 0.1 || p.z() > params_.kinect.max_range_m) return false;
  const CameraIntrinsics& k = params_.intrinsics;
  const Eigen::Vector2d px = k.project(p);
  return px.x() >= margin_px && px.y() >= margin_px && px.x() <= k.width - margin_px &&
         px.y() <= k.height - margin_px;
}

}  // namespace shapesense::synthetic::detail
