// LayoutBuilder's outline and the bookkeeping its steps share.

#include <array>
#include <utility>

#include "layout.h"
#include "world_geometry.h"

namespace shapesense::synthetic::detail {

Eigen::Vector3f jitterColour(Rng& rng, Eigen::Vector3f bgr, double amount) {
  const float scale = static_cast<float>(rng.uniform(1.0 - amount, 1.0 + amount));
  return (bgr * scale).cwiseMin(255.0f);
}

LayoutBuilder::LayoutBuilder(const SceneParams& params)
    : params_(params),
      rng_(layoutSeed(params.seed)),
      model_(std::make_unique<SceneModel>()),
      extra_rng_(extraLayoutSeed(params.seed)) {}

std::unique_ptr<const SceneModel> LayoutBuilder::build() {
  if (params_.free_look) {
    placeFreeLookCamera();
  } else {
    placeCameraAndTable();
  }
  if (params_.camera_roll_max_deg > 0.0) withExtraStream([this] { addCameraRoll(); });
  addRoom();
  addTable();
  addSeveral(params_.boxes_on_table_min, params_.boxes_on_table_max, &LayoutBuilder::addTableBox);
  if (rng_.chance(params_.floor_box_probability)) addFloorBox();
  addSeveral(params_.bowls_min, params_.bowls_max, &LayoutBuilder::addBowl);
  addSeveral(params_.cups_min, params_.cups_max, &LayoutBuilder::addCup);
  addSeveral(params_.tins_min, params_.tins_max, &LayoutBuilder::addTin);
  addSeveral(params_.balls_min, params_.balls_max, &LayoutBuilder::addBall);
  model_->sway = drawSway(rng_);
  if (anyExtras()) withExtraStream([this] { addExtras(); });
  return std::move(model_);
}

void LayoutBuilder::addSeveral(int min_count, int max_count, void (LayoutBuilder::*add)()) {
  const int count = rng_.uniformInt(min_count, max_count);
  for (int i = 0; i < count; ++i) (this->*add)();
}

std::uint16_t LayoutBuilder::addSurface(std::string name, SurfaceKind kind,
                                        const Eigen::Vector4d& plane, std::uint16_t object_id,
                                        const Eigen::Vector3f& colour) {
  model_->surfaces.push_back({std::move(name), kind, plane, object_id, colour.cwiseMin(255.0f)});
  return static_cast<std::uint16_t>(model_->surfaces.size());
}

std::uint16_t LayoutBuilder::addObject(const ObjectDef& object) {
  model_->objects.push_back(object);
  return static_cast<std::uint16_t>(model_->objects.size());
}

void LayoutBuilder::addSolid(std::unique_ptr<const Solid> solid, const Eigen::Isometry3d& pose,
                             std::uint16_t object_id, const std::string& name_prefix,
                             const FaceColour& colour_of) {
  const std::vector<FaceLabel> labels = solid->faces();
  std::vector<std::uint16_t> surface_of_face;
  for (std::size_t f = 0; f < labels.size(); ++f) {
    const FaceLabel& label = labels[f];
    Eigen::Vector4d plane = Eigen::Vector4d::Zero();
    if (label.kind == SurfaceKind::kPlane) plane = worldPlane(pose, label.normal, label.point);
    surface_of_face.push_back(addSurface(name_prefix + label.name, label.kind, plane, object_id,
                                         colour_of(static_cast<int>(f), label)));
  }
  model_->primitives.push_back({std::move(solid), pose, object_id, std::move(surface_of_face)});
}

void LayoutBuilder::addShadedSolid(std::unique_ptr<const Solid> solid, const ObjectDef& object,
                                   std::uint16_t object_id, const Eigen::Vector3f& colour) {
  addSolid(std::move(solid), object.world_from_object, object_id, object.name,
           [&](int, const FaceLabel& label) -> Eigen::Vector3f { return colour * label.shade; });
}

void LayoutBuilder::addBoxSolid(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half,
                                std::uint16_t object_id, const std::string& name_prefix,
                                const Eigen::Vector3f& colour, BoxSolid::FaceNames face_names) {
  addSolid(std::make_unique<BoxSolid>(half, std::move(face_names)), pose, object_id, name_prefix,
           [&](int, const FaceLabel&) { return jitterColour(rng_, colour, 0.06); });
}

std::string LayoutBuilder::nextObjectName(const std::string& kind) {
  return kind + std::to_string(++objects_of_kind_[kind]);
}

std::uint16_t LayoutBuilder::addSolidObject(ObjectDef object, std::unique_ptr<const Solid> solid,
                                            const Eigen::Vector3f& colour) {
  object.local_box = solid->bounds();
  const std::uint16_t id = addObject(object);
  addShadedSolid(std::move(solid), object, id, colour);
  return id;
}

Eigen::Vector3f LayoutBuilder::objectColour() {
  static constexpr std::array<std::array<float, 3>, 8> kPalette = {{
      {60, 60, 200},
      {60, 170, 60},
      {200, 110, 40},
      {40, 180, 220},
      {170, 60, 160},
      {230, 230, 230},
      {90, 140, 200},
      {50, 50, 60},
  }};
  const auto& c =
      kPalette[static_cast<std::size_t>(rng_.uniformInt(0, static_cast<int>(kPalette.size()) - 1))];
  return jitterColour(rng_, Eigen::Vector3f(c[0], c[1], c[2]), 0.15);
}

}  // namespace shapesense::synthetic::detail
