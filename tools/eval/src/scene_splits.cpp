#include "shapesense/eval/scene_splits.h"

#include <random>

#include "random_draws.h"

namespace shapesense::eval {
namespace {

// Far apart so that no split reaches another's seeds, and far from the small seeds the unit
// tests and the bowl training use.
std::uint64_t splitSeedBase(Split split) {
  switch (split) {
    case Split::kTrain:
      return 1'000'000;
    case Split::kValidation:
      return 2'000'000;
    case Split::kTest:
      return 3'000'000;
  }
  return 0;
}

using detail::chance;
using detail::uniform;
using detail::uniformInt;

void drawCamera(std::mt19937_64& rng, synthetic::SceneParams& p) {
  p.camera_motion = uniform(rng, 0.0, 1.5);
  // Some roll on most scenes: a robot head is never quite level.
  if (chance(rng, 0.6)) p.camera_roll_max_deg = uniform(rng, 2.0, 10.0);
  if (chance(rng, 0.4)) {
    // Free look: any height 0.4-2 m, pitched 0-60 deg down, towards a random point of the
    // table area, in a room of 3-7 m by 3-7 m by 2.4-3 m.
    p.free_look = true;
    p.free_look_height_min_m = p.free_look_height_max_m = uniform(rng, 0.4, 2.0);
    p.free_look_pitch_min_deg = p.free_look_pitch_max_deg = uniform(rng, 0.0, 60.0);
    p.free_look_table_distance_min_m = 0.8;
    p.free_look_table_distance_max_m = uniform(rng, 1.2, 3.5);
    p.free_look_target_spread_m = uniform(rng, 0.0, 1.5);
    return;
  }
  // The generator aims the camera at the table and lowers the far end of the distance range
  // until the view elevation is reached, so the range starts near enough for any height.
  const double height = uniform(rng, 0.95, 1.8);
  p.camera_height_min_m = p.camera_height_max_m = height;
  p.table_distance_min_m = 0.8;
  p.table_distance_max_m = uniform(rng, 1.2, 3.2);
  p.min_table_elevation_deg = uniform(rng, 8.0, 20.0);
}

void drawObjects(std::mt19937_64& rng, bool curved_clutter, synthetic::SceneParams& p) {
  p.boxes_on_table_min = p.boxes_on_table_max = uniformInt(rng, 1, 6);
  p.floor_box_probability = uniform(rng, 0.0, 1.0);
  // Boxes of 3-60 cm, stacked and touching; thin objects 1-3 cm proud; shelves.
  if (chance(rng, 0.5)) p.extra_boxes_min = p.extra_boxes_max = uniformInt(rng, 1, 5);
  if (chance(rng, 0.4)) p.stacked_boxes_min = p.stacked_boxes_max = uniformInt(rng, 1, 3);
  if (chance(rng, 0.4)) p.touching_box_pairs_min = p.touching_box_pairs_max = uniformInt(rng, 1, 2);
  if (chance(rng, 0.5)) p.thin_objects_min = p.thin_objects_max = uniformInt(rng, 1, 4);
  if (chance(rng, 0.35)) p.shelves_min = p.shelves_max = 1;
  p.thin_object_lids = curved_clutter;  // a lid's rim is curved
  if (!curved_clutter) {
    p.bowls_min = p.bowls_max = 0;
    p.cups_min = p.cups_max = 0;
    p.tins_min = p.tins_max = 0;
    p.balls_min = p.balls_max = 0;
    return;
  }
  p.bowls_min = p.bowls_max = uniformInt(rng, 0, 3);
  p.bowl_upside_down_probability = uniform(rng, 0.0, 0.3);
  p.cups_min = p.cups_max = uniformInt(rng, 0, 2);
  p.tins_min = p.tins_max = uniformInt(rng, 1, 3);
  p.balls_min = p.balls_max = uniformInt(rng, 0, 2);
  if (chance(rng, 0.5)) p.lying_tins_min = p.lying_tins_max = uniformInt(rng, 1, 2);
  if (chance(rng, 0.4)) p.bins_min = p.bins_max = uniformInt(rng, 1, 2);
  if (chance(rng, 0.2)) p.columns_min = p.columns_max = 1;
  if (chance(rng, 0.3)) p.tori_min = p.tori_max = uniformInt(rng, 1, 2);
  if (chance(rng, 0.2)) p.mounds_min = p.mounds_max = 1;
}

void drawSensor(std::mt19937_64& rng, synthetic::KinectParams& k) {
  k.disparity_noise_px = uniform(rng, 0.04, 0.15);
  k.dropout_rate = uniform(rng, 0.0, 0.01);
  k.max_incidence_deg = uniform(rng, 75.0, 85.0);
  if (chance(rng, 0.5)) {
    k.flying_pixel_rate = uniform(rng, 0.05, 0.4);
    k.flying_pixel_min_jump_m = uniform(rng, 0.03, 0.1);
  }
  if (chance(rng, 0.5)) {
    k.holes_min = 1;
    k.holes_max = uniformInt(rng, 1, 8);
    k.hole_radius_min_px = 3.0;
    k.hole_radius_max_px = uniform(rng, 6.0, 25.0);
  }
}

}  // namespace

std::string_view formatSplit(Split split) {
  switch (split) {
    case Split::kTrain:
      return "train";
    case Split::kValidation:
      return "validation";
    case Split::kTest:
      return "test";
  }
  return "?";
}

std::optional<Split> parseSplit(std::string_view name) {
  if (name == "train") return Split::kTrain;
  if (name == "validation" || name == "val") return Split::kValidation;
  if (name == "test") return Split::kTest;
  return std::nullopt;
}

EvalScene evalScene(Split split, int index) {
  const std::uint64_t seed = splitSeedBase(split) + static_cast<std::uint64_t>(index);
  std::mt19937_64 rng(seed);
  EvalScene scene;
  scene.params.seed = seed;
  scene.params.render_colour = false;
  scene.curved_clutter = index % 2 == 1;
  drawCamera(rng, scene.params);
  drawObjects(rng, scene.curved_clutter, scene.params);
  drawSensor(rng, scene.params.kinect);
  scene.frame_index = static_cast<std::uint64_t>(uniformInt(rng, 0, 600));
  return scene;
}

}  // namespace shapesense::eval
