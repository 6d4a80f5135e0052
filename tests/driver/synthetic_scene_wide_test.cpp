// Tests of the synthetic scene's wider distribution (issue #18): each optional feature appears
// with exact truth (its surfaces exist, are labelled in the image, planar ones fit their plane),
// leaves the rest of the scene where it was, and is off by default.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::synthetic {
namespace {

RenderedFrame renderFrame(SceneParams params, std::uint64_t seed, std::uint64_t index = 0) {
  params.seed = seed;
  params.render_colour = false;
  return SyntheticScene(params).render(index, 0);
}

bool startsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

const TruthObject* objectOf(const TruthFrame& t, std::uint16_t id) {
  return id == 0 ? nullptr : &t.objects.at(id - 1u);
}

Eigen::Vector3d toWorld(const TruthFrame& t, const Eigen::Vector3d& camera_point) {
  return t.world_from_camera * camera_point;
}

/// The lowest and highest world z of an object's box.
std::pair<double, double> worldZRange(const TruthFrame& t, const TruthObject& o) {
  double lo = 1e9, hi = -1e9;
  for (const Eigen::Vector3d& c : o.corners) {
    const double z = toWorld(t, c).z();
    lo = std::min(lo, z), hi = std::max(hi, z);
  }
  return {lo, hi};
}

/// The invariants every frame keeps: labels exactly where the depth is valid, object labels
/// agree with surface labels, counts agree, and every labelled pixel of a planar surface has an
/// ideal depth on its plane within 1 mm. Returns the planar surfaces checked (with pixels).
int checkTruth(const RenderedFrame& f) {
  const TruthFrame& t = f.truth;
  const CameraIntrinsics& k = f.frame.intrinsics;
  std::vector<std::size_t> counts(t.surfaces.size() + 1, 0);
  std::vector<double> worst(t.surfaces.size() + 1, 0.0);
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const std::uint16_t depth = f.frame.depth.at<std::uint16_t>(v, u);
      const std::uint16_t s = t.surface_labels.at<std::uint16_t>(v, u);
      const std::uint16_t o = t.object_labels.at<std::uint16_t>(v, u);
      EXPECT_EQ(depth != 0, s != 0) << u << "," << v;
      if (s == 0) continue;
      const TruthSurface& surface = t.surfaces.at(s - 1u);
      EXPECT_EQ(surface.object_id, o);
      ++counts[s];
      const double z = t.ideal_depth.at<float>(v, u);
      EXPECT_GT(z, 0.0);
      if (surface.kind != SurfaceKind::kPlane) continue;
      const double dist = surface.plane.head<3>().dot(k.backproject(u, v, z)) + surface.plane.w();
      worst[s] = std::max(worst[s], std::abs(dist));
    }
  int planar = 0;
  for (const TruthSurface& s : t.surfaces) {
    EXPECT_EQ(s.pixel_count, counts[s.id]) << s.name;
    if (s.kind == SurfaceKind::kPlane) {
      EXPECT_NEAR(s.plane.head<3>().norm(), 1.0, 1e-9) << s.name;
      EXPECT_GE(s.plane.w(), 0.0) << s.name;
      EXPECT_LT(worst[s.id], 1e-3) << s.name;
      planar += s.pixel_count > 0;
    } else {
      EXPECT_EQ(s.plane, Eigen::Vector4d::Zero()) << s.name;
    }
  }
  return planar;
}

/// Seeds 1..max_seed rendered with `params`; calls `check` on each and counts how many it
/// accepts.
int countScenes(const SceneParams& params, int max_seed,
                const std::function<bool(const RenderedFrame&)>& check) {
  int found = 0;
  for (int seed = 1; seed <= max_seed; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const RenderedFrame f = renderFrame(params, static_cast<std::uint64_t>(seed));
    checkTruth(f);
    found += check(f);
  }
  return found;
}

/// Surfaces of objects of `kind` with pixels in the image, by surface kind.
std::map<SurfaceKind, int> visibleSurfacesOfKind(const TruthFrame& t, const std::string& kind) {
  std::map<SurfaceKind, int> out;
  for (const TruthSurface& s : t.surfaces) {
    const TruthObject* o = objectOf(t, s.object_id);
    if (o && o->kind == kind && s.pixel_count > 0) ++out[s.kind];
  }
  return out;
}

TEST(SyntheticSceneWide, DefaultsSwitchEveryFeatureOff) {
  const SceneParams p;
  EXPECT_EQ(p.camera_roll_max_deg, 0.0);
  EXPECT_FALSE(p.free_look);
  EXPECT_EQ(p.extra_boxes_max + p.stacked_boxes_max + p.touching_box_pairs_max +
                p.thin_objects_max + p.shelves_max + p.lying_tins_max + p.bins_max + p.columns_max +
                p.tori_max + p.mounds_max,
            0);
  EXPECT_EQ(p.kinect.flying_pixel_rate, 0.0);
  EXPECT_EQ(p.kinect.holes_max, 0);
}

TEST(SyntheticSceneWide, AdditionsLeaveTheSceneWhereItWas) {
  SceneParams more;
  more.extra_boxes_min = more.extra_boxes_max = 2;
  more.stacked_boxes_min = more.stacked_boxes_max = 1;
  more.thin_objects_min = more.thin_objects_max = 2;
  more.shelves_min = more.shelves_max = 1;
  more.bins_min = more.bins_max = 1;
  for (std::uint64_t seed : {1, 2, 3}) {
    const RenderedFrame a = renderFrame(SceneParams{}, seed, 4);
    const RenderedFrame b = renderFrame(more, seed, 4);
    EXPECT_TRUE(a.truth.world_from_camera.isApprox(b.truth.world_from_camera, 0.0));
    ASSERT_GT(b.truth.surfaces.size(), a.truth.surfaces.size());
    for (std::size_t i = 0; i < a.truth.surfaces.size(); ++i) {
      EXPECT_EQ(a.truth.surfaces[i].name, b.truth.surfaces[i].name);
      EXPECT_EQ(a.truth.surfaces[i].plane, b.truth.surfaces[i].plane);
    }
    for (std::size_t i = 0; i < a.truth.objects.size(); ++i)
      EXPECT_TRUE(a.truth.objects[i].center.isApprox(b.truth.objects[i].center, 0.0));
    // Where neither frame sees an added object, the pixels are the same (but for the projector
    // shadows the added objects cast).
    int same = 0, compared = 0;
    for (int v = 0; v < 480; ++v)
      for (int u = 0; u < 640; ++u) {
        if (b.truth.object_labels.at<std::uint16_t>(v, u) > a.truth.objects.size()) continue;
        if (a.truth.ideal_depth.at<float>(v, u) != b.truth.ideal_depth.at<float>(v, u)) continue;
        if (b.frame.depth.at<std::uint16_t>(v, u) == 0) continue;
        ++compared;
        same += a.frame.depth.at<std::uint16_t>(v, u) == b.frame.depth.at<std::uint16_t>(v, u);
      }
    EXPECT_GT(compared, 100000);
    EXPECT_EQ(same, compared);
  }
}

TEST(SyntheticSceneWide, SameParamsGiveSameFrames) {
  SceneParams p;
  p.free_look = true;
  p.camera_roll_max_deg = 10.0;
  p.thin_objects_max = 3;
  p.shelves_max = 1;
  p.kinect.flying_pixel_rate = 0.3;
  p.kinect.holes_min = 2;
  p.kinect.holes_max = 6;
  const RenderedFrame a = renderFrame(p, 9, 2), b = renderFrame(p, 9, 2);
  EXPECT_EQ(cv::norm(a.frame.depth, b.frame.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.truth.surface_labels, b.truth.surface_labels, cv::NORM_INF), 0.0);
}

TEST(SyntheticSceneWide, CameraRollStaysWithinItsRange) {
  SceneParams p;
  p.camera_motion = 0.0;
  p.camera_roll_max_deg = 10.0;
  double largest = 0.0;
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    const RenderedFrame f = renderFrame(p, seed);
    // lookAt keeps the camera's x axis level before rolling: its world z is sin(roll).
    const Eigen::Vector3d x_axis = f.truth.world_from_camera.linear().col(0);
    const double roll_deg = std::asin(x_axis.z()) * 180.0 / std::numbers::pi;
    EXPECT_LE(std::abs(roll_deg), 11.0 + 1e-9);
    largest = std::max(largest, std::abs(roll_deg));
  }
  EXPECT_GT(largest, 6.0);
}

TEST(SyntheticSceneWide, FreeLookCoversHeightsPitchesAndRoomSizes) {
  SceneParams p;
  p.free_look = true;
  p.camera_motion = 0.0;
  double min_height = 9, max_height = 0, min_pitch = 90, max_pitch = -90;
  int near_plane_frames = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const RenderedFrame f = renderFrame(p, seed);
    const TruthFrame& t = f.truth;
    checkTruth(f);
    const double height = t.world_from_camera.translation().z();
    EXPECT_GE(height, p.free_look_height_min_m);
    EXPECT_LE(height, p.free_look_height_max_m);
    const Eigen::Vector3d forward = t.world_from_camera.linear().col(2);
    const double pitch = -std::asin(forward.z()) * 180.0 / std::numbers::pi;
    EXPECT_GE(pitch, p.free_look_pitch_min_deg - 1e-9);
    EXPECT_LE(pitch, p.free_look_pitch_max_deg + 1e-9);
    min_height = std::min(min_height, height), max_height = std::max(max_height, height);
    min_pitch = std::min(min_pitch, pitch), max_pitch = std::max(max_pitch, pitch);
    // The room: opposite walls 3-7 m apart (more only when camera and table need it), the
    // ceiling 2.4-3 m up; the camera inside.
    std::map<std::string, Eigen::Vector3d> on_wall;  // a world point of each room face
    for (const TruthSurface& s : t.surfaces)
      if (s.object_id == 0) on_wall[s.name] = toWorld(t, -s.plane.w() * s.plane.head<3>());
    const double width = on_wall["wall_right"].x() - on_wall["wall_left"].x();
    const double depth = on_wall["wall_back"].y() - on_wall["wall_front"].y();
    EXPECT_GE(width, p.room_extent_min_m - 1e-9);
    EXPECT_GE(depth, p.room_extent_min_m - 1e-9);
    EXPECT_LE(std::min(width, depth), p.room_extent_max_m + 1e-9);
    EXPECT_NEAR(on_wall["floor"].z(), 0.0, 1e-9);
    EXPECT_GE(on_wall["ceiling"].z(), p.room_height_min_m - 1e-9);
    EXPECT_LE(on_wall["ceiling"].z(), std::max(p.room_height_max_m, height + 0.3) + 1e-9);
    const Eigen::Vector3d eye = t.world_from_camera.translation();
    EXPECT_GT(eye.x(), on_wall["wall_left"].x());
    EXPECT_LT(eye.x(), on_wall["wall_right"].x());
    EXPECT_GT(eye.y(), on_wall["wall_front"].y());
    EXPECT_LT(eye.y(), on_wall["wall_back"].y());
    // The camera is not over or under the table.
    const TruthObject& table = t.objects.front();
    ASSERT_EQ(table.kind, "table");
    const Eigen::Vector3d in_table =
        table.rotation.transpose() * (Eigen::Vector3d::Zero() - table.center);
    EXPECT_TRUE(std::abs(in_table.x()) > table.size.x() / 2 ||
                std::abs(in_table.y()) > table.size.y() / 2);
    std::size_t valid = 0;
    for (const TruthSurface& s : t.surfaces) valid += s.pixel_count;
    near_plane_frames += valid > 100000;
  }
  EXPECT_LT(min_height, 0.7);
  EXPECT_GT(max_height, 1.7);
  EXPECT_LT(min_pitch, 10.0);
  EXPECT_GT(max_pitch, 45.0);
  EXPECT_GT(near_plane_frames, 20);  // most views see plenty
}

TEST(SyntheticSceneWide, ExtraBoxesSpanThreeToSixtyCentimetres) {
  SceneParams p;
  p.extra_boxes_min = p.extra_boxes_max = 4;
  double smallest = 1.0, largest = 0.0;
  int on_floor = 0;
  const int scenes = countScenes(p, 10, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    int boxes = 0;
    for (const TruthObject& o : t.objects) {
      if (o.kind != "box") continue;
      ++boxes;
      smallest = std::min(smallest, o.size.minCoeff());
      largest = std::max(largest, o.size.maxCoeff());
      EXPECT_GE(o.size.minCoeff(), 0.03 - 1e-12) << o.name;
      on_floor += std::abs(worldZRange(t, o).first) < 1e-9;
    }
    return boxes >= 5;
  });
  EXPECT_GE(scenes, 8);
  EXPECT_LT(smallest, 0.05);
  EXPECT_GT(largest, 0.45);
  EXPECT_GT(on_floor, 5);
}

TEST(SyntheticSceneWide, StackedBoxesRestInsideTheTopOfABox) {
  SceneParams p;
  p.stacked_boxes_min = p.stacked_boxes_max = 2;
  int stacked = 0;
  countScenes(p, 10, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    bool any = false;
    for (const TruthObject& upper : t.objects) {
      if (upper.kind != "box") continue;
      const double bottom = worldZRange(t, upper).first;
      for (const TruthObject& lower : t.objects) {
        if (lower.kind != "box" || lower.id == upper.id) continue;
        if (std::abs(worldZRange(t, lower).second - bottom) > 1e-9) continue;
        // Every bottom corner of the upper box lies within the lower box's top.
        for (int c = 0; c < 4; ++c) {
          const Eigen::Vector3d in_lower =
              lower.rotation.transpose() *
              (upper.corners[static_cast<std::size_t>(c)] - lower.center);
          EXPECT_LE(std::abs(in_lower.x()), lower.size.x() / 2 + 1e-9) << upper.name;
          EXPECT_LE(std::abs(in_lower.y()), lower.size.y() / 2 + 1e-9) << upper.name;
        }
        // Both tops are planes, parallel, labelled, upper.size.z apart.
        const TruthSurface* top_upper = nullptr;
        const TruthSurface* top_lower = nullptr;
        for (const TruthSurface& s : t.surfaces) {
          if (s.name == upper.name + "_face_top") top_upper = &s;
          if (s.name == lower.name + "_face_top") top_lower = &s;
        }
        if (!top_upper || !top_lower) {
          ADD_FAILURE() << "no top faces for " << upper.name << " on " << lower.name;
          continue;
        }
        const auto height = [&](const TruthSurface& s) {
          return toWorld(t, -s.plane.w() * s.plane.head<3>()).z();
        };
        EXPECT_NEAR(std::abs(top_upper->plane.head<3>().dot(top_lower->plane.head<3>())), 1.0,
                    1e-9);
        EXPECT_NEAR(height(*top_upper) - height(*top_lower), upper.size.z(), 1e-9);
        any |= top_upper->pixel_count > 50;
        ++stacked;
      }
    }
    return any;
  });
  EXPECT_GE(stacked, 12);
}

TEST(SyntheticSceneWide, TouchingBoxesShareAYawAndAreAtMostOneCentimetreApart) {
  SceneParams p;
  p.boxes_on_table_min = p.boxes_on_table_max = 0;
  p.floor_box_probability = 0.0;
  p.touching_box_pairs_min = p.touching_box_pairs_max = 1;
  int pairs = 0, shared_top = 0, close_tops = 0;
  countScenes(p, 16, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    std::vector<const TruthObject*> boxes;
    for (const TruthObject& o : t.objects)
      if (o.kind == "box") boxes.push_back(&o);
    if (boxes.size() != 2) return false;
    const TruthObject& a = *boxes[0];
    const TruthObject& b = *boxes[1];
    EXPECT_TRUE(a.rotation.isApprox(b.rotation, 1e-9));
    // Along the pair's x: a's right face to b's left face is the gap.
    const Eigen::Vector3d offset = a.rotation.transpose() * (b.center - a.center);
    const double gap = std::abs(offset.x()) - (a.size.x() + b.size.x()) / 2;
    EXPECT_GE(gap, -1e-9);
    EXPECT_LE(gap, 0.01 + 1e-9);
    const double dz = std::abs(worldZRange(t, a).second - worldZRange(t, b).second);
    shared_top += dz < 1e-9;
    close_tops += dz > 0.01 - 1e-9 && dz < 0.03 + 1e-9;
    ++pairs;
    return true;
  });
  EXPECT_GE(pairs, 12);
  EXPECT_GE(shared_top, 2);
  EXPECT_GE(close_tops, 2);
}

TEST(SyntheticSceneWide, ThinObjectsLieOneToThreeCentimetresProud) {
  SceneParams p;
  p.thin_objects_min = p.thin_objects_max = 3;
  std::set<std::string> kinds;
  int on_boxes = 0, seen_tops = 0;
  countScenes(p, 12, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    const double table_top = t.objects.front().size.z();
    for (const TruthObject& o : t.objects) {
      if (o.kind != "book" && o.kind != "board" && o.kind != "lid") continue;
      kinds.insert(o.kind);
      const double thickness = o.size.z();
      EXPECT_GE(thickness, 0.01 - 1e-12) << o.name;
      EXPECT_LE(thickness, 0.03 + 1e-12) << o.name;
      const double bottom = worldZRange(t, o).first;
      if (std::abs(bottom - table_top) > 1e-9) ++on_boxes;
      const std::string top_name = o.name + (o.kind == "lid" ? "_top" : "_face_top");
      for (const TruthSurface& s : t.surfaces) {
        if (s.object_id != o.id) continue;
        if (o.kind == "lid" && startsWith(s.name, o.name + "_side")) {
          EXPECT_EQ(s.kind, SurfaceKind::kCurved);
        }
        if (s.name == top_name) {
          EXPECT_EQ(s.kind, SurfaceKind::kPlane);
          seen_tops += s.pixel_count > 30;
        }
      }
    }
    return true;
  });
  EXPECT_EQ(kinds, (std::set<std::string>{"board", "book", "lid"}));
  EXPECT_GE(on_boxes, 3);
  EXPECT_GE(seen_tops, 15);

  // Without lids, thin objects have planar faces only.
  p.thin_object_lids = false;
  p.bowls_min = p.bowls_max = p.cups_max = p.tins_max = p.balls_max = 0;
  int thin = 0;
  countScenes(p, 6, [&](const RenderedFrame& f) {
    for (const TruthObject& o : f.truth.objects) {
      EXPECT_NE(o.kind, "lid");
      thin += o.kind == "book" || o.kind == "board";
    }
    for (const TruthSurface& s : f.truth.surfaces) EXPECT_EQ(s.kind, SurfaceKind::kPlane) << s.name;
    return true;
  });
  EXPECT_GE(thin, 12);
}

TEST(SyntheticSceneWide, ShelvesStandAgainstAWallWithBoards) {
  SceneParams p;
  p.shelves_min = p.shelves_max = 1;
  int shelves = 0, seen = 0;
  countScenes(p, 12, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    for (const TruthObject& o : t.objects) {
      if (o.kind != "shelf") continue;
      ++shelves;
      int boards = 0;
      for (const TruthSurface& s : t.surfaces)
        if (s.object_id == o.id) {
          EXPECT_EQ(s.kind, SurfaceKind::kPlane) << s.name;
          boards += s.name.find("_board") != std::string::npos &&
                    s.name.find("_face_top") != std::string::npos;
        }
      EXPECT_GE(boards, 2);
      EXPECT_LE(boards, 4);
      // Its back (local +y side) is within 3 cm of a wall.
      const Eigen::Vector3d back = o.center + o.rotation.col(1) * o.size.y() / 2;
      double nearest = 1e9;
      for (const TruthSurface& s : t.surfaces)
        if (startsWith(s.name, "wall_"))
          nearest = std::min(nearest, std::abs(s.plane.head<3>().dot(back) + s.plane.w()));
      EXPECT_LE(nearest, 0.03 + 1e-9) << o.name;
      EXPECT_NEAR(worldZRange(t, o).first, 0.0, 1e-9);
      seen += o.pixel_count > 2000;
    }
    return true;
  });
  EXPECT_GE(shelves, 8);
  EXPECT_GE(seen, 5);
}

TEST(SyntheticSceneWide, LyingTinsBinsAndColumnsAreCurved) {
  SceneParams p;
  p.lying_tins_min = p.lying_tins_max = 2;
  p.bins_min = p.bins_max = 1;
  p.columns_min = p.columns_max = 1;
  p.tins_min = p.tins_max = 0;
  int lying = 0;
  std::map<std::string, int> curved_seen;
  countScenes(p, 12, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    for (const TruthObject& o : t.objects) {
      if (o.kind == "tin") {
        // The axis is level and the tin rests on the table top.
        const Eigen::Vector3d axis_world = t.world_from_camera.linear() * o.rotation.col(2);
        EXPECT_NEAR(axis_world.z(), 0.0, 1e-9);
        const double table_top = t.objects.front().size.z();
        const Eigen::Vector3d centre = toWorld(t, o.center);
        EXPECT_NEAR(centre.z() - table_top, o.size.x() / 2, 1e-9) << o.name;
        ++lying;
      }
      if (o.kind == "bin" || o.kind == "column") {
        EXPECT_NEAR(worldZRange(t, o).first, 0.0, 1e-9) << o.name;
      }
    }
    for (const std::string kind : {"tin", "bin", "column"})
      curved_seen[kind] += visibleSurfacesOfKind(t, kind)[SurfaceKind::kCurved] > 0;
    return true;
  });
  EXPECT_GE(lying, 16);
  EXPECT_GE(curved_seen["tin"], 8);
  EXPECT_GE(curved_seen["bin"], 6);
  EXPECT_GE(curved_seen["column"], 4);
}

TEST(SyntheticSceneWide, ToriAndMoundsAreCurvedAndLieOnTheirSurfaces) {
  SceneParams p;
  p.tori_min = p.tori_max = 2;
  p.mounds_min = p.mounds_max = 1;
  p.bowls_min = p.bowls_max = 0;
  p.cups_max = p.tins_max = p.balls_max = 0;
  int tori = 0, mounds = 0;
  const CameraIntrinsics k;
  countScenes(p, 10, [&](const RenderedFrame& f) {
    const TruthFrame& t = f.truth;
    const double table_top = t.objects.front().size.z();
    for (const TruthObject& o : t.objects) {
      if (o.kind != "torus" && o.kind != "mound") continue;
      EXPECT_NEAR(worldZRange(t, o).first, table_top, 1e-9) << o.name;
      const double tube = o.size.z() / 2, ring = o.size.x() / 2 - tube;
      double worst = 0.0;
      std::size_t pixels = 0;
      for (int v = 0; v < 480; ++v)
        for (int u = 0; u < 640; ++u) {
          if (t.object_labels.at<std::uint16_t>(v, u) != o.id) continue;
          ++pixels;
          const std::uint16_t s = t.surface_labels.at<std::uint16_t>(v, u);
          const TruthSurface& surface = t.surfaces.at(s - 1u);
          const Eigen::Vector3d local =
              o.rotation.transpose() *
              (k.backproject(u, v, t.ideal_depth.at<float>(v, u)) - o.center);
          if (o.kind == "torus") {
            EXPECT_EQ(surface.kind, SurfaceKind::kCurved);
            // On the torus: at the tube radius from the ring.
            worst = std::max(
                worst,
                std::abs(std::hypot(std::hypot(local.x(), local.y()) - ring, local.z()) - tube));
          } else {
            EXPECT_EQ(surface.name, o.name + "_top");
            EXPECT_EQ(surface.kind, SurfaceKind::kCurved);
            // Inside its box, above its base.
            const Eigen::Vector3d outside = (local.cwiseAbs() - o.size / 2).cwiseMax(0.0);
            worst = std::max(worst, outside.norm());
          }
        }
      EXPECT_LT(worst, 1e-3) << o.name;
      (o.kind == "torus" ? tori : mounds) += pixels > 100;
    }
    return true;
  });
  EXPECT_GE(tori, 8);
  EXPECT_GE(mounds, 4);
}

TEST(SyntheticSceneWide, FlyingPixelsLieBetweenTheTwoSidesOfAnEdge) {
  SceneParams p;
  p.camera_motion = 0.0;
  p.kinect.disparity_noise_px = 0.0;
  p.kinect.dropout_rate = 0.0;
  const RenderedFrame clean = renderFrame(p, 5);
  p.kinect.flying_pixel_rate = 0.5;
  const RenderedFrame flying = renderFrame(p, 5);
  checkTruth(flying);
  const cv::Mat& ideal = flying.truth.ideal_depth;
  EXPECT_EQ(cv::norm(clean.truth.ideal_depth, ideal, cv::NORM_INF), 0.0);
  int moved = 0, differing = 0;
  for (int v = 1; v < 479; ++v)
    for (int u = 1; u < 639; ++u) {
      const int a = clean.frame.depth.at<std::uint16_t>(v, u);
      const int b = flying.frame.depth.at<std::uint16_t>(v, u);
      if (a == b) continue;
      ++differing;
      if (b == 0) continue;  // moved out of range
      // A flying pixel sits next to a depth step and its depth is within the step's span.
      const double z = ideal.at<float>(v, u);
      double lo = z, hi = z;
      for (const auto& [du, dv] :
           {std::pair{-1, 0}, std::pair{1, 0}, std::pair{0, -1}, std::pair{0, 1}}) {
        const double zn = ideal.at<float>(v + dv, u + du);
        if (zn > 0.0 && std::abs(zn - z) > p.kinect.flying_pixel_min_jump_m)
          lo = std::min(lo, zn), hi = std::max(hi, zn);
      }
      const double measured = b / 1000.0, step = measured * measured * 0.125 / 43.5;
      EXPECT_GE(measured, lo - step - 1e-3) << u << "," << v;
      EXPECT_LE(measured, hi + step + 1e-3) << u << "," << v;
      moved += hi > lo;
    }
  EXPECT_GT(moved, 300);
  EXPECT_GT(moved, differing * 8 / 10);  // the rest: edges against out-of-range depth
}

TEST(SyntheticSceneWide, HolesAreBlobsWithoutDepthThatMoveFromFrameToFrame) {
  SceneParams p;
  p.kinect.holes_min = p.kinect.holes_max = 6;
  p.kinect.hole_radius_min_px = 8.0;
  p.kinect.hole_radius_max_px = 20.0;
  const auto lostPixels = [](const RenderedFrame& f) {
    cv::Mat lost = (f.truth.ideal_depth > 0.0f) & (f.frame.depth == 0);
    return lost;
  };
  const RenderedFrame plain1 = renderFrame(SceneParams{}, 6, 1);
  const RenderedFrame plain2 = renderFrame(SceneParams{}, 6, 2);
  const RenderedFrame a = renderFrame(p, 6, 1);
  const RenderedFrame b = renderFrame(p, 6, 2);
  checkTruth(a);
  checkTruth(b);
  const cv::Mat lost_a = lostPixels(a);
  const cv::Mat holes_a = lost_a & ~lostPixels(plain1);
  const cv::Mat holes_b = lostPixels(b) & ~lostPixels(plain2);
  const int with_holes = cv::countNonZero(holes_a);
  EXPECT_GT(with_holes, 6 * 100);  // six blobs of at least ~200 pixels, some overlap or cut
  EXPECT_LT(with_holes, 6 * 3 * 1300);
  EXPECT_GT(cv::countNonZero(holes_b), 6 * 100);
  // Outside the holes nothing changes.
  int changed_outside = 0;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u)
      if (!lost_a.at<std::uint8_t>(v, u))
        changed_outside +=
            a.frame.depth.at<std::uint16_t>(v, u) != plain1.frame.depth.at<std::uint16_t>(v, u);
  EXPECT_EQ(changed_outside, 0);
  // Another frame, other holes.
  EXPECT_LT(cv::countNonZero(holes_a & holes_b), with_holes / 2);
}

TEST(SyntheticSceneWide, EverythingAtOnceKeepsExactTruth) {
  SceneParams p;
  p.free_look = true;
  p.camera_roll_max_deg = 10.0;
  p.extra_boxes_max = 3;
  p.stacked_boxes_max = 2;
  p.touching_box_pairs_max = 2;
  p.thin_objects_min = 2;
  p.thin_objects_max = 4;
  p.shelves_max = 1;
  p.lying_tins_max = 2;
  p.bins_max = 1;
  p.columns_max = 1;
  p.tori_max = 1;
  p.mounds_max = 1;
  p.kinect.flying_pixel_rate = 0.3;
  p.kinect.holes_max = 8;
  int planar = 0;
  std::set<std::string> kinds;
  for (std::uint64_t seed = 1; seed <= 16; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    p.free_look = seed % 2 == 0;  // free-look views often miss the table
    const RenderedFrame f = renderFrame(p, seed, seed);
    planar += checkTruth(f);
    std::set<std::string> names;
    for (const TruthSurface& s : f.truth.surfaces)
      EXPECT_TRUE(names.insert(s.name).second) << s.name;
    for (const TruthObject& o : f.truth.objects)
      if (o.pixel_count > 0) kinds.insert(o.kind);
  }
  EXPECT_GT(planar, 16 * 8);
  for (const char* kind : {"table", "box", "book", "board", "lid", "shelf", "tin", "bin"})
    EXPECT_TRUE(kinds.count(kind)) << kind;
}

TEST(SyntheticSceneWide, RejectsImpossibleParams) {
  const auto rejects = [](const std::function<void(SceneParams&)>& change) {
    SceneParams p;
    change(p);
    EXPECT_THROW(SyntheticScene{p}, std::invalid_argument);
  };
  rejects([](SceneParams& p) { p.camera_roll_max_deg = -1.0; });
  rejects([](SceneParams& p) {
    p.free_look = true;
    p.free_look_height_min_m = 2.5;
  });
  rejects([](SceneParams& p) {
    p.free_look = true;
    p.free_look_pitch_max_deg = 89.0;
  });
  rejects([](SceneParams& p) { p.extra_box_size_min_m = 0.0; });
  rejects([](SceneParams& p) { p.stacked_boxes_min = 3; });
  rejects([](SceneParams& p) { p.shelves_min = -1; });
  rejects([](SceneParams& p) { p.tori_min = 1; });
  rejects([](SceneParams& p) { p.kinect.flying_pixel_rate = 1.5; });
  rejects([](SceneParams& p) { p.kinect.holes_min = 2; });
  rejects([](SceneParams& p) { p.kinect.hole_radius_min_px = 0.0; });
}

}  // namespace
}  // namespace shapesense::synthetic
