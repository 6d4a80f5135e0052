#include "truth_builder.h"

#include <utility>

namespace shapesense::synthetic::detail {

void TruthBuilder::build(TruthFrame& truth) const {
  truth.world_from_camera = world_from_camera_;
  const LabelStatistics labels = countLabels(truth);
  truth.surfaces = surfaceTruths(labels);
  truth.objects = objectTruths(labels);
}

TruthBuilder::LabelStatistics TruthBuilder::countLabels(const TruthFrame& truth) const {
  LabelStatistics labels{std::vector<std::size_t>(model_.surfaces.size() + 1, 0),
                         std::vector<std::size_t>(model_.objects.size() + 1, 0),
                         std::vector<cv::Rect>(model_.objects.size() + 1)};
  for (int v = 0; v < truth.surface_labels.rows; ++v) {
    const auto* surface_row = truth.surface_labels.ptr<std::uint16_t>(v);
    const auto* object_row = truth.object_labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < truth.surface_labels.cols; ++u) {
      ++labels.surface_pixels[surface_row[u]];
      const std::uint16_t o = object_row[u];
      if (o == 0) continue;
      if (labels.object_pixels[o]++ == 0) {
        labels.object_boxes[o] = cv::Rect(u, v, 1, 1);
      } else {
        labels.object_boxes[o] |= cv::Rect(u, v, 1, 1);
      }
    }
  }
  return labels;
}

std::vector<TruthSurface> TruthBuilder::surfaceTruths(const LabelStatistics& labels) const {
  std::vector<TruthSurface> surfaces;
  for (std::size_t s = 0; s < model_.surfaces.size(); ++s) {
    const SurfaceDef& def = model_.surfaces[s];
    TruthSurface out;
    out.id = static_cast<std::uint16_t>(s + 1);
    out.name = def.name;
    out.kind = def.kind;
    out.object_id = def.object_id;
    out.pixel_count = labels.surface_pixels[s + 1];
    if (def.kind == SurfaceKind::kPlane) out.plane = cameraPlane(def.world_plane);
    surfaces.push_back(std::move(out));
  }
  return surfaces;
}

std::vector<TruthObject> TruthBuilder::objectTruths(const LabelStatistics& labels) const {
  std::vector<TruthObject> objects;
  for (std::size_t o = 0; o < model_.objects.size(); ++o) {
    TruthObject out = objectTruth(model_.objects[o]);
    out.id = static_cast<std::uint16_t>(o + 1);
    out.pixel_count = labels.object_pixels[o + 1];
    out.image_box = labels.object_boxes[o + 1];
    if (model_.objects[o].bowl && out.pixel_count > 0) {
      const double area = bowlSilhouetteArea(out);
      out.visible_fraction = area > 0 ? static_cast<double>(out.pixel_count) / area : 0.0;
    }
    objects.push_back(std::move(out));
  }
  return objects;
}

Eigen::Vector4d TruthBuilder::cameraPlane(const Eigen::Vector4d& world_plane) const {
  const Eigen::Vector3d n_world = world_plane.head<3>();
  const double scale = 1.0 / n_world.norm();
  const Eigen::Vector3d n = world_from_camera_.linear().transpose() * n_world * scale;
  const double d = (n_world.dot(world_from_camera_.translation()) + world_plane.w()) * scale;
  const double sign = d < 0.0 ? -1.0 : 1.0;
  return {sign * n.x(), sign * n.y(), sign * n.z(), sign * d};
}

TruthObject TruthBuilder::objectTruth(const ObjectDef& def) const {
  const Eigen::Isometry3d camera_from_object = world_from_camera_.inverse() * def.world_from_object;
  TruthObject out;
  out.kind = def.kind;
  out.name = def.name;
  out.center = camera_from_object * def.local_box.center();
  out.size = def.local_box.sizes();
  out.rotation = camera_from_object.linear();
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d signs((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
    out.corners[static_cast<std::size_t>(i)] =
        out.center + out.rotation * signs.cwiseProduct(out.size / 2.0);
  }
  if (def.bowl) addBowlShape(def, camera_from_object, out);
  return out;
}

}  // namespace shapesense::synthetic::detail
