// SyntheticScene: checks the params, has the layout generated once, and renders each frame as
// ray casting (ray_caster), the sensor model (sensor_model) and ground truth (truth_builder).

#include "shapesense/driver/synthetic_scene.h"

#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "layout.h"
#include "ray_caster.h"
#include "scene_model.h"
#include "sensor_model.h"
#include "truth_builder.h"

namespace shapesense::synthetic {

namespace {

void validate(const SceneParams& p) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SceneParams: ") + what);
  };
  const CameraIntrinsics& k = p.intrinsics;
  require(k.width > 0 && k.height > 0 && k.fx > 0 && k.fy > 0, "intrinsics must be positive");
  require(p.frame_rate_hz > 0, "frame_rate_hz must be positive");
  require(p.camera_motion >= 0, "camera_motion must not be negative");
  require(p.camera_height_min_m <= p.camera_height_max_m, "camera height range is empty");
  require(p.table_distance_min_m > 0 && p.table_distance_min_m <= p.table_distance_max_m,
          "table distance range is empty");
  require(p.min_table_elevation_deg > 0 && p.min_table_elevation_deg < 90,
          "min_table_elevation_deg out of (0, 90)");
  require(p.boxes_on_table_min >= 0 && p.boxes_on_table_min <= p.boxes_on_table_max,
          "box count range");
  require(p.bowls_min >= 0 && p.bowls_min <= p.bowls_max, "bowl count range");
  require(p.cups_min >= 0 && p.cups_min <= p.cups_max, "cup count range");
  require(p.tins_min >= 0 && p.tins_min <= p.tins_max, "tin count range");
  require(p.balls_min >= 0 && p.balls_min <= p.balls_max, "ball count range");
  const KinectParams& kp = p.kinect;
  require(kp.focal_baseline_px_m > 0 && kp.disparity_step_px > 0,
          "disparity model must be positive");
  require(kp.disparity_noise_px >= 0 && kp.dropout_rate >= 0 && kp.dropout_rate <= 1,
          "noise params");
  require(kp.min_range_m > 0 && kp.min_range_m < kp.max_range_m && kp.max_range_m < 65.0,
          "range limits");
  require(kp.projector_baseline_m >= 0, "projector_baseline_m must not be negative");
  require(kp.flying_pixel_rate >= 0 && kp.flying_pixel_rate <= 1 && kp.flying_pixel_min_jump_m > 0,
          "flying pixel params");
  require(kp.holes_min >= 0 && kp.holes_min <= kp.holes_max, "hole count range");
  require(kp.hole_radius_min_px > 0 && kp.hole_radius_min_px <= kp.hole_radius_max_px,
          "hole radius range");
  require(p.camera_roll_max_deg >= 0 && p.camera_roll_max_deg <= 45,
          "camera_roll_max_deg out of [0, 45]");
  if (p.free_look) {
    require(p.free_look_height_min_m > 0 && p.free_look_height_min_m <= p.free_look_height_max_m,
            "free-look height range");
    require(p.free_look_pitch_min_deg >= -30 &&
                p.free_look_pitch_min_deg <= p.free_look_pitch_max_deg &&
                p.free_look_pitch_max_deg <= 80,
            "free-look pitch range out of [-30, 80]");
    require(p.free_look_table_distance_min_m > 0 &&
                p.free_look_table_distance_min_m <= p.free_look_table_distance_max_m,
            "free-look table distance range");
    require(p.free_look_target_spread_m >= 0, "free_look_target_spread_m must not be negative");
    require(p.room_extent_min_m > 0 && p.room_extent_min_m <= p.room_extent_max_m,
            "room extent range");
    require(p.room_height_min_m >= 1.0 && p.room_height_min_m <= p.room_height_max_m,
            "room height range");
  }
  require(p.extra_box_size_min_m > 0 && p.extra_box_size_min_m <= p.extra_box_size_max_m,
          "extra box size range");
  for (const auto& [lo, hi, what] :
       {std::tuple{p.extra_boxes_min, p.extra_boxes_max, "extra box count range"},
        std::tuple{p.stacked_boxes_min, p.stacked_boxes_max, "stacked box count range"},
        std::tuple{p.touching_box_pairs_min, p.touching_box_pairs_max, "box pair count range"},
        std::tuple{p.thin_objects_min, p.thin_objects_max, "thin object count range"},
        std::tuple{p.shelves_min, p.shelves_max, "shelf count range"},
        std::tuple{p.lying_tins_min, p.lying_tins_max, "lying tin count range"},
        std::tuple{p.bins_min, p.bins_max, "bin count range"},
        std::tuple{p.columns_min, p.columns_max, "column count range"},
        std::tuple{p.tori_min, p.tori_max, "torus count range"},
        std::tuple{p.mounds_min, p.mounds_max, "mound count range"}})
    require(lo >= 0 && lo <= hi, what);
}

}  // namespace

SyntheticScene::SyntheticScene(SceneParams params) : params_(std::move(params)) {
  validate(params_);
  model_ = detail::LayoutBuilder(params_).build();
}

SyntheticScene::~SyntheticScene() = default;
SyntheticScene::SyntheticScene(SyntheticScene&&) noexcept = default;
SyntheticScene& SyntheticScene::operator=(SyntheticScene&&) noexcept = default;

Eigen::Isometry3d SyntheticScene::worldFromCamera(std::uint64_t index) const {
  const double seconds = static_cast<double>(index) / params_.frame_rate_hz;
  return model_->base_world_from_camera * model_->sway.at(seconds, params_.camera_motion);
}

RenderedFrame SyntheticScene::render(std::uint64_t index, TimestampNs timestamp_ns) const {
  return render(index, timestamp_ns, worldFromCamera(index));
}

RenderedFrame SyntheticScene::render(std::uint64_t index, TimestampNs timestamp_ns,
                                     const Eigen::Isometry3d& world_from_camera) const {
  const CameraIntrinsics& k = params_.intrinsics;

  detail::HitBuffer hits(k.width + detail::projectorShadowColumns(params_), k.height);
  detail::RayCaster caster(k, world_from_camera, hits);
  for (const detail::Primitive& primitive : model_->primitives) caster.cast(primitive);

  RenderedFrame out;
  out.frame.intrinsics = k;
  out.frame.timestamp_ns = timestamp_ns;
  out.frame.sequence = index;
  detail::SensorModel(params_, *model_, index).apply(hits, world_from_camera, out.frame, out.truth);
  detail::TruthBuilder(*model_, world_from_camera, k).build(out.truth);
  return out;
}

}  // namespace shapesense::synthetic
