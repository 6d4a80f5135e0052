#include "shapesense/eval/recognition_views.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <string_view>

#include "random_draws.h"

namespace shapesense::eval {
namespace {

using detail::chance;
using detail::uniform;
using detail::uniformInt;

// Beyond evalScene's bases (1'000'000-3'000'000 plus index) and a million apart.
std::uint64_t recognitionSeedBase(Split split) {
  switch (split) {
    case Split::kTrain:
      return 4'000'000;
    case Split::kValidation:
      return 5'000'000;
    case Split::kTest:
      return 6'000'000;
  }
  return 0;
}

void drawLayout(std::mt19937_64& rng, synthetic::SceneParams& p) {
  p.camera_motion = 0.0;  // the views differ by the drawn poses only
  const double height = uniform(rng, 0.9, 1.6);
  p.camera_height_min_m = p.camera_height_max_m = height;
  p.table_distance_min_m = 0.7;
  p.table_distance_max_m = 2.0;
  p.boxes_on_table_min = p.boxes_on_table_max = uniformInt(rng, 2, 4);
  p.floor_box_probability = 0.0;
  p.extra_boxes_min = p.extra_boxes_max = uniformInt(rng, 1, 2);
  p.extra_box_size_min_m = 0.05;
  p.extra_box_size_max_m = 0.25;
  const int boxes = p.boxes_on_table_max + p.extra_boxes_max;
  if (boxes < 6 && chance(rng, 0.3)) p.stacked_boxes_min = p.stacked_boxes_max = 1;
  if (chance(rng, 0.4)) p.thin_objects_min = p.thin_objects_max = uniformInt(rng, 1, 2);
  p.cups_min = p.cups_max = uniformInt(rng, 0, 2);
  p.tins_min = p.tins_max = uniformInt(rng, 0, 2);
  p.bowls_min = p.bowls_max = uniformInt(rng, 0, 1);
  p.balls_min = p.balls_max = 0;
  p.kinect.disparity_noise_px = uniform(rng, 0.05, 0.1);
}

const synthetic::TruthObject& table(const synthetic::TruthFrame& truth) {
  const auto it = std::find_if(truth.objects.begin(), truth.objects.end(),
                               [](const synthetic::TruthObject& o) { return o.kind == "table"; });
  if (it == truth.objects.end()) throw std::logic_error("recognitionCase: scene has no table");
  return *it;
}

// What the other views orbit about and look at, in world coordinates.
struct Orbit {
  Eigen::Vector3d pivot;  ///< the table's centre (only its x, y matter: the axis is vertical)
  Eigen::Vector3d aim;    ///< where the teach camera's optical axis meets the table-top plane
};

Orbit orbitOf(const synthetic::TruthFrame& teach) {
  const synthetic::TruthObject& t = table(teach);
  const Eigen::Isometry3d& pose = teach.world_from_camera;
  const Eigen::Vector3d pivot = pose * t.center;
  const double top = pivot.z() + t.size.z() / 2.0;  // the table's box reaches from the floor
  const Eigen::Vector3d eye = pose.translation();
  const Eigen::Vector3d forward = pose.linear().col(2);
  // The generator aims every table-top camera down at the table; the pivot is a fallback.
  if (forward.z() > -1e-3) return {pivot, {pivot.x(), pivot.y(), top}};
  return {pivot, eye + forward * ((top - eye.z()) / forward.z())};
}

// The teach pose turned by `azimuth` about the vertical through the pivot, raised by `rise`,
// and tilted about its own x axis (keeping its roll) until it looks at the orbited aim again.
Eigen::Isometry3d orbitPose(const Eigen::Isometry3d& teach, const Orbit& orbit, double azimuth,
                            double rise) {
  const Eigen::Isometry3d turn = Eigen::Translation3d(orbit.pivot) *
                                 Eigen::AngleAxisd(azimuth, Eigen::Vector3d::UnitZ()) *
                                 Eigen::Translation3d(-orbit.pivot);
  Eigen::Isometry3d pose = turn * teach;
  pose.translation().z() += rise;
  const Eigen::Vector3d to_aim =
      pose.linear().transpose() * (turn * orbit.aim - pose.translation());
  const double tilt = std::atan2(-to_aim.y(), to_aim.z());
  pose.linear() =
      pose.linear() * Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return pose;
}

// The camera stays inside the room, clear of its walls, floor and ceiling, and beside the table
// (the rule the scene generator places the teach camera by).
bool cameraFits(const Eigen::Vector3d& eye, const synthetic::TruthFrame& teach) {
  constexpr double kWallClearance = 0.3;
  constexpr double kTableClearance = 0.15;
  const Eigen::Isometry3d& pose = teach.world_from_camera;
  for (const synthetic::TruthSurface& s : teach.surfaces) {
    if (s.object_id != 0 || s.kind != synthetic::SurfaceKind::kPlane) continue;
    // The room's planes: n points to the camera's side, which is the inside.
    const Eigen::Vector3d n = pose.linear() * s.plane.head<3>();
    const double d = s.plane.w() - n.dot(pose.translation());
    if (n.dot(eye) + d < kWallClearance) return false;
  }
  const synthetic::TruthObject& t = table(teach);
  const Eigen::Matrix3d world_from_table = pose.linear() * t.rotation;
  const Eigen::Vector3d local = world_from_table.transpose() * (eye - pose * t.center);
  const Eigen::Vector2d outside =
      (local.head<2>().cwiseAbs() - t.size.head<2>() / 2.0).cwiseMax(0.0);
  return outside.norm() >= kTableClearance;
}

Eigen::Isometry3d drawOtherPose(std::mt19937_64& rng, const synthetic::TruthFrame& teach) {
  const Orbit orbit = orbitOf(teach);
  for (int attempt = 0; attempt < 200; ++attempt) {
    const double magnitude_deg = uniform(rng, 10.0, 35.0);
    const bool clockwise = chance(rng, 0.5);
    const double rise = uniform(rng, -0.15, 0.15);
    const double azimuth = (clockwise ? -1.0 : 1.0) * magnitude_deg * std::numbers::pi / 180.0;
    const Eigen::Isometry3d pose = orbitPose(teach.world_from_camera, orbit, azimuth, rise);
    if (cameraFits(pose.translation(), teach)) return pose;
  }
  throw std::runtime_error("recognitionCase: no room for another view around the table");
}

RecognitionView renderView(const synthetic::SyntheticScene& scene, std::uint64_t frame_index,
                           const Eigen::Isometry3d& world_from_camera) {
  return {scene.render(frame_index, 0, world_from_camera), world_from_camera};
}

const synthetic::TruthObject* objectById(const synthetic::TruthFrame& truth, std::uint16_t id) {
  // Objects are ordered by id, from 1.
  if (id == 0 || id > truth.objects.size()) return nullptr;
  return &truth.objects[id - 1u];
}

bool teachableKind(std::string_view kind) {
  static constexpr std::array<std::string_view, 9> kKinds = {"box", "book", "board", "lid",  "cup",
                                                             "tin", "bowl", "torus", "mound"};
  return std::find(kKinds.begin(), kKinds.end(), kind) != kKinds.end();
}

}  // namespace

RecognitionCase recognitionCase(Split split, int index, int other_views) {
  if (index < 0 || other_views < 0)
    throw std::invalid_argument("recognitionCase: index and other_views must not be negative");
  const std::uint64_t seed = recognitionSeedBase(split) + static_cast<std::uint64_t>(index);
  std::mt19937_64 rng(seed);
  RecognitionCase c;
  c.params.seed = seed;
  c.params.render_colour = false;
  drawLayout(rng, c.params);
  const synthetic::SyntheticScene scene(c.params);
  c.teach = renderView(scene, 0, scene.worldFromCamera(0));
  for (int v = 0; v < other_views; ++v) {
    const Eigen::Isometry3d pose = drawOtherPose(rng, c.teach.rendered.truth);
    c.others.push_back(renderView(scene, static_cast<std::uint64_t>(v) + 1, pose));
  }
  return c;
}

Eigen::Isometry3d teachToView(const RecognitionCase& c, const RecognitionView& view) {
  return view.world_from_camera.inverse() * c.teach.world_from_camera;
}

std::vector<std::uint16_t> teachableObjects(const RecognitionCase& c) {
  constexpr int kMinSidePx = 24;
  constexpr std::size_t kMinPixels = 2000;
  const synthetic::TruthFrame& truth = c.teach.rendered.truth;
  const cv::Rect image(0, 0, truth.object_labels.cols, truth.object_labels.rows);
  std::vector<std::uint16_t> ids;
  for (const synthetic::TruthObject& o : truth.objects) {
    const cv::Rect& b = o.image_box;
    const bool inside = b.x > 0 && b.y > 0 && b.br().x < image.width && b.br().y < image.height;
    if (teachableKind(o.kind) && b.width >= kMinSidePx && b.height >= kMinSidePx &&
        o.pixel_count >= kMinPixels && inside)
      ids.push_back(o.id);
  }
  return ids;
}

double visibleShare(const RecognitionCase& c, const RecognitionView& view,
                    std::uint16_t object_id) {
  const synthetic::TruthObject* taught = objectById(c.teach.rendered.truth, object_id);
  const synthetic::TruthObject* seen = objectById(view.rendered.truth, object_id);
  if (taught == nullptr || seen == nullptr || taught->pixel_count == 0) return 0.0;
  return std::min(
      1.0, static_cast<double>(seen->pixel_count) / static_cast<double>(taught->pixel_count));
}

}  // namespace shapesense::eval
