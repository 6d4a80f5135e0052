// Tests of the synthetic scene: determinism, camera motion, the Kinect sensor model and the
// consistency of the ground truth with the rendered pixels.

#include "shapesense/driver/synthetic_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

#include <opencv2/core.hpp>

namespace shapesense::synthetic {
namespace {

constexpr double kFocalBaseline = 43.5;

RenderedFrame renderFrame(std::uint64_t seed, std::uint64_t index = 0, SceneParams params = {}) {
  params.seed = seed;
  return SyntheticScene(params).render(index, 0);
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

double depthStep(double z) { return z * z * 0.125 / kFocalBaseline; }

const TruthSurface& surfaceById(const TruthFrame& truth, std::uint16_t id) {
  return truth.surfaces.at(id - 1u);
}

Eigen::Vector3d cameraUp(const TruthFrame& truth) {
  return truth.world_from_camera.linear().transpose() * Eigen::Vector3d::UnitZ();
}

TEST(SyntheticScene, SameSeedGivesSameFramesWhateverTheCallOrder) {
  const SyntheticScene a(SceneParams{});
  const SyntheticScene b(SceneParams{});
  const RenderedFrame a3 = a.render(3, 0);
  const RenderedFrame a5 = a.render(5, 0);
  const RenderedFrame b5 = b.render(5, 0);
  const RenderedFrame b3 = b.render(3, 0);
  for (const auto& [x, y] : {std::pair{&a3, &b3}, std::pair{&a5, &b5}}) {
    EXPECT_TRUE(identical(x->frame.depth, y->frame.depth));
    EXPECT_TRUE(identical(x->frame.rgb, y->frame.rgb));
    EXPECT_TRUE(identical(x->truth.surface_labels, y->truth.surface_labels));
    EXPECT_TRUE(identical(x->truth.object_labels, y->truth.object_labels));
    EXPECT_TRUE(identical(x->truth.ideal_depth, y->truth.ideal_depth));
    EXPECT_TRUE(x->truth.world_from_camera.isApprox(y->truth.world_from_camera, 0.0));
  }
}

TEST(SyntheticScene, DifferentSeedsGiveDifferentScenes) {
  const RenderedFrame one = renderFrame(1);
  const RenderedFrame two = renderFrame(2);
  const double differing = cv::countNonZero(one.frame.depth != two.frame.depth);
  EXPECT_GT(differing / one.frame.depth.total(), 0.3);
}

TEST(SyntheticScene, FrameCarriesIntrinsicsStampAndSequence) {
  const SyntheticScene scene(SceneParams{});
  const RenderedFrame f = scene.render(7, 123456789);
  EXPECT_EQ(f.frame.sequence, 7u);
  EXPECT_EQ(f.frame.timestamp_ns, 123456789);
  EXPECT_EQ(f.frame.intrinsics, CameraIntrinsics{});
  EXPECT_EQ(f.frame.depth.type(), CV_16UC1);
  EXPECT_EQ(f.frame.rgb.type(), CV_8UC3);
  EXPECT_EQ(f.frame.depth.size(), cv::Size(640, 480));
  EXPECT_EQ(f.truth.surface_labels.type(), CV_16UC1);
  EXPECT_EQ(f.truth.object_labels.type(), CV_16UC1);
  EXPECT_EQ(f.truth.ideal_depth.type(), CV_32FC1);
  // Most of the image has depth: the room encloses the camera.
  EXPECT_GT(cv::countNonZero(f.frame.depth), 0.6 * 640 * 480);
}

TEST(SyntheticScene, CameraSwaysSlowlyWhenMotionIsOn) {
  const SyntheticScene scene(SceneParams{});
  const Eigen::Isometry3d first = scene.worldFromCamera(0);
  double max_offset = 0.0, max_angle = 0.0, max_step = 0.0;
  Eigen::Isometry3d previous = first;
  for (std::uint64_t i = 1; i <= 600; ++i) {  // 20 s at 30 fps
    const Eigen::Isometry3d pose = scene.worldFromCamera(i);
    const Eigen::Isometry3d delta = first.inverse() * pose;
    max_offset = std::max(max_offset, delta.translation().norm());
    max_angle = std::max(max_angle, Eigen::AngleAxisd(delta.linear()).angle());
    max_step = std::max(max_step, (previous.inverse() * pose).translation().norm());
    previous = pose;
  }
  EXPECT_GT(max_offset, 0.01);  // moves by more than a centimetre...
  EXPECT_LT(max_offset, 0.15);  // ...but only sways
  EXPECT_GT(max_angle * 180 / std::numbers::pi, 0.5);
  EXPECT_LT(max_angle * 180 / std::numbers::pi, 5.0);
  EXPECT_LT(max_step, 0.005);  // < 5 mm per frame: smooth
  const RenderedFrame f0 = scene.render(0, 0);
  const RenderedFrame f30 = scene.render(30, 0);
  EXPECT_FALSE(identical(f0.truth.ideal_depth, f30.truth.ideal_depth));
  EXPECT_TRUE(f30.truth.world_from_camera.isApprox(scene.worldFromCamera(30)));
}

TEST(SyntheticScene, StaticCameraGivesIdenticalGeometryButFreshNoise) {
  SceneParams params;
  params.camera_motion = 0.0;
  const SyntheticScene scene(params);
  const RenderedFrame f0 = scene.render(0, 0);
  const RenderedFrame f45 = scene.render(45, 0);
  EXPECT_TRUE(identical(f0.truth.ideal_depth, f45.truth.ideal_depth));
  EXPECT_TRUE(f0.truth.world_from_camera.isApprox(f45.truth.world_from_camera, 0.0));
  EXPECT_FALSE(identical(f0.frame.depth, f45.frame.depth));  // the sensor noise is per frame
}

TEST(SyntheticScene, RenderingFromTheFramesOwnPoseIsTheSameFrame) {
  const SyntheticScene scene(SceneParams{});
  const RenderedFrame plain = scene.render(17, 42);
  const RenderedFrame posed = scene.render(17, 42, scene.worldFromCamera(17));
  EXPECT_TRUE(identical(plain.frame.depth, posed.frame.depth));
  EXPECT_TRUE(identical(plain.frame.rgb, posed.frame.rgb));
  EXPECT_TRUE(identical(plain.truth.surface_labels, posed.truth.surface_labels));
  EXPECT_TRUE(identical(plain.truth.object_labels, posed.truth.object_labels));
  EXPECT_TRUE(identical(plain.truth.ideal_depth, posed.truth.ideal_depth));
  EXPECT_TRUE(plain.truth.world_from_camera.isApprox(posed.truth.world_from_camera, 0.0));
  EXPECT_EQ(posed.frame.sequence, 17u);
  EXPECT_EQ(posed.frame.timestamp_ns, 42);
  ASSERT_EQ(plain.truth.objects.size(), posed.truth.objects.size());
  for (std::size_t i = 0; i < plain.truth.objects.size(); ++i) {
    EXPECT_EQ(plain.truth.objects[i].center, posed.truth.objects[i].center);
    EXPECT_EQ(plain.truth.objects[i].pixel_count, posed.truth.objects[i].pixel_count);
  }
}

// Share of the object's pixels in `from` whose ideal 3D point, moved into `to`'s camera frame,
// lands on a pixel of `to` that shows that same point (ideal depth within 5 mm); points that
// leave the image are not counted.
double shareSeenAgain(const TruthFrame& from, const TruthFrame& to, std::uint16_t object_id) {
  const CameraIntrinsics k;
  const Eigen::Isometry3d to_from_from = to.world_from_camera.inverse() * from.world_from_camera;
  std::size_t inside = 0, same = 0;
  for (int v = 0; v < from.object_labels.rows; ++v)
    for (int u = 0; u < from.object_labels.cols; ++u) {
      if (from.object_labels.at<std::uint16_t>(v, u) != object_id) continue;
      const Eigen::Vector3d p =
          to_from_from * k.backproject(u, v, from.ideal_depth.at<float>(v, u));
      const Eigen::Vector2d px = k.project(p);
      const int pu = static_cast<int>(std::lround(px.x()));
      const int pv = static_cast<int>(std::lround(px.y()));
      if (pu < 0 || pv < 0 || pu >= to.ideal_depth.cols || pv >= to.ideal_depth.rows) continue;
      ++inside;
      same += std::abs(to.ideal_depth.at<float>(pv, pu) - p.z()) < 0.005;
    }
  return inside > 0 ? static_cast<double>(same) / static_cast<double>(inside) : 0.0;
}

TEST(SyntheticScene, ACameraMovedSidewaysSeesTheObjectsMovedTheOtherWay) {
  SceneParams params;
  params.camera_motion = 0.0;
  const SyntheticScene scene(params);
  const Eigen::Isometry3d pose = scene.worldFromCamera(0);
  const Eigen::Isometry3d moved = pose * Eigen::Translation3d(0.1, 0.0, 0.0);  // 10 cm right
  const RenderedFrame before = scene.render(0, 0);
  const RenderedFrame after = scene.render(0, 0, moved);
  EXPECT_TRUE(after.truth.world_from_camera.isApprox(moved, 0.0));
  EXPECT_FALSE(identical(before.truth.ideal_depth, after.truth.ideal_depth));
  ASSERT_EQ(before.truth.objects.size(), after.truth.objects.size());
  for (std::size_t i = 0; i < before.truth.objects.size(); ++i) {
    const TruthObject& a = before.truth.objects[i];
    const TruthObject& b = after.truth.objects[i];
    EXPECT_LT((b.center - (a.center - Eigen::Vector3d(0.1, 0.0, 0.0))).norm(), 1e-9) << a.name;
    EXPECT_TRUE(b.rotation.isApprox(a.rotation, 1e-12)) << a.name;  // a pure translation
  }
  // The rendering moved too: the boxes' pixels are found again where the truth transform puts
  // them (not all: a box can hide part of another from the new viewpoint, and a pixel is
  // rounded to the nearest in the other view, which misses at steep depth edges).
  int checked = 0;
  for (const TruthObject& o : before.truth.objects) {
    if (o.kind != "box" || o.pixel_count < 500) continue;
    EXPECT_GT(shareSeenAgain(before.truth, after.truth, o.id), 0.8) << o.name;
    TruthFrame unmoved = after.truth;  // the new pixels under the old pose: they do not agree
    unmoved.world_from_camera = pose;
    EXPECT_LT(shareSeenAgain(before.truth, unmoved, o.id), 0.5) << o.name;
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(SyntheticScene, LayoutIsPlausible) {
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const SceneParams params;
    const RenderedFrame f = renderFrame(seed);
    const TruthFrame& t = f.truth;
    std::map<std::string, int> kinds;
    for (const TruthObject& o : t.objects) ++kinds[o.kind];
    EXPECT_EQ(kinds["table"], 1);
    EXPECT_GE(kinds["box"], 2);
    EXPECT_GE(kinds["bowl"], 1);

    std::set<std::string> names;
    for (const TruthSurface& s : t.surfaces) EXPECT_TRUE(names.insert(s.name).second) << s.name;

    // Camera at robot height, looking down at the table from 0.8-2.5 m.
    const double camera_height = t.world_from_camera.translation().z();
    EXPECT_GE(camera_height, params.camera_height_min_m - 0.1);
    EXPECT_LE(camera_height, params.camera_height_max_m + 0.1);
    const TruthObject& table = t.objects.front();
    ASSERT_EQ(table.kind, "table");
    EXPECT_GT(table.pixel_count, 5000u);
    const Eigen::Vector3d top_centre = table.center + table.rotation.col(2) * table.size.z() / 2;
    EXPECT_GT(top_centre.norm(), params.table_distance_min_m - 0.1);
    EXPECT_LT(top_centre.norm(), params.table_distance_max_m + 0.1);
    const double table_height = table.size.z();

    // Floor and at least two walls are seen.
    int walls = 0;
    bool floor = false;
    for (const TruthSurface& s : t.surfaces) {
      if (s.object_id != 0 || s.pixel_count < 500) continue;
      floor |= s.name == "floor";
      walls += s.name.rfind("wall_", 0) == 0;
    }
    EXPECT_TRUE(floor);
    EXPECT_GE(walls, 2);

    // Every object rests on the floor or on the table top, and footprints on the same support
    // keep apart (footprint radius: half diagonal of a box's base, radius of a round object).
    struct Footprint {
      Eigen::Vector2d c;
      double r;
      double support;
    };
    std::vector<Footprint> footprints;
    for (const TruthObject& o : t.objects) {
      if (o.kind == "table") continue;
      double lowest = 1e9;
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3d& c : o.corners) {
        const Eigen::Vector3d w = t.world_from_camera * c;
        lowest = std::min(lowest, w.z());
        centre += w / 8.0;
      }
      const bool on_floor = std::abs(lowest) < 1e-6;
      const bool on_table = std::abs(lowest - table_height) < 1e-6;
      EXPECT_TRUE(on_floor || on_table) << o.name << " bottom at " << lowest;
      const double r = o.kind == "box" ? 0.5 * std::hypot(o.size.x(), o.size.y()) : o.size.x() / 2;
      footprints.push_back({centre.head<2>(), r, lowest});
    }
    for (std::size_t i = 0; i < footprints.size(); ++i)
      for (std::size_t j = i + 1; j < footprints.size(); ++j) {
        if (std::abs(footprints[i].support - footprints[j].support) > 1e-3) continue;
        EXPECT_GE((footprints[i].c - footprints[j].c).norm(), footprints[i].r + footprints[j].r);
      }
  }
}

TEST(SyntheticScene, LabelsAgreeWithValidDepthAndCounts) {
  const RenderedFrame f = renderFrame(3);
  const TruthFrame& t = f.truth;
  std::vector<std::size_t> surface_counts(t.surfaces.size() + 1, 0);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const std::uint16_t depth = f.frame.depth.at<std::uint16_t>(v, u);
      const std::uint16_t s = t.surface_labels.at<std::uint16_t>(v, u);
      const std::uint16_t o = t.object_labels.at<std::uint16_t>(v, u);
      ASSERT_EQ(depth != 0, s != 0) << u << "," << v;
      if (s == 0) {
        ASSERT_EQ(o, 0);
        continue;
      }
      ASSERT_EQ(surfaceById(t, s).object_id, o);
      ASSERT_GT(t.ideal_depth.at<float>(v, u), 0.0f);
      ++surface_counts[s];
    }
  for (const TruthSurface& s : t.surfaces) EXPECT_EQ(s.pixel_count, surface_counts[s.id]) << s.name;
}

TEST(SyntheticScene, PlanarSurfacesFitTheirPlanes) {
  const CameraIntrinsics k;
  int checked = 0;
  for (std::uint64_t seed : {1, 4}) {
    const RenderedFrame f = renderFrame(seed);
    const TruthFrame& t = f.truth;
    for (const TruthSurface& s : t.surfaces) {
      if (s.kind != SurfaceKind::kPlane || s.pixel_count < 300) continue;
      SCOPED_TRACE(s.name);
      EXPECT_NEAR(s.plane.head<3>().norm(), 1.0, 1e-9);
      EXPECT_GT(s.plane.w(), 0.0);
      double max_ideal = 0.0, sum_sq = 0.0, sum_sq_steps = 0.0;
      std::vector<double> zs;
      for (int v = 0; v < 480; ++v)
        for (int u = 0; u < 640; ++u) {
          if (t.surface_labels.at<std::uint16_t>(v, u) != s.id) continue;
          const double z_ideal = t.ideal_depth.at<float>(v, u);
          const double z = f.frame.depth.at<std::uint16_t>(v, u) / 1000.0;
          max_ideal =
              std::max(max_ideal,
                       std::abs(s.plane.head<3>().dot(k.backproject(u, v, z_ideal)) + s.plane.w()));
          const double dist = s.plane.head<3>().dot(k.backproject(u, v, z)) + s.plane.w();
          sum_sq += dist * dist;
          sum_sq_steps += std::pow(dist / depthStep(z_ideal), 2);
          zs.push_back(z);
        }
      std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
      const double n = static_cast<double>(zs.size());
      // Noise-free depth lies on the plane (float storage only).
      EXPECT_LT(max_ideal, 1e-4);
      // Measured: sigma 0.07 px plus 1/8 px quantisation is ~0.6 steps RMS along the ray.
      EXPECT_LT(std::sqrt(sum_sq / n), 2.0 * depthStep(zs[zs.size() / 2]));
      EXPECT_LT(std::sqrt(sum_sq_steps / n), 1.0);
      ++checked;
    }
  }
  EXPECT_GT(checked, 15);
}

TEST(SyntheticScene, MeasuredDepthTakesQuantisedDisparityLevels) {
  const RenderedFrame f = renderFrame(2);
  std::set<int> mm_between_2_and_2_1;
  int checked = 0;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const int mm = f.frame.depth.at<std::uint16_t>(v, u);
      if (mm < 1000) continue;
      const double z = mm / 1000.0;
      const double level = kFocalBaseline / z / 0.125;
      // Rounding z to whole millimetres moves the disparity by up to fb * 0.5 mm / z^2 (with z
      // the smaller of the two).
      const double tolerance =
          kFocalBaseline * 0.0005 / ((z - 0.0005) * (z - 0.0005)) / 0.125 + 1e-9;
      ASSERT_LE(std::abs(level - std::round(level)), tolerance) << "z = " << z;
      if (mm >= 2000 && mm < 2100) mm_between_2_and_2_1.insert(mm);
      ++checked;
    }
  EXPECT_GT(checked, 10000);
  // 2.0-2.1 m spans 43.5/2 - 43.5/2.1 = 1.04 px of disparity: about 8 levels, not 100 mm values.
  EXPECT_GE(mm_between_2_and_2_1.size(), 5u);
  EXPECT_LE(mm_between_2_and_2_1.size(), 10u);
}

TEST(SyntheticScene, DisparityNoiseHasTheConfiguredSpread) {
  // A static camera sees the same ideal depth in every frame; the measured disparity spread
  // around it must match sigma (with the 1/8 px quantisation added in quadrature).
  SceneParams params;
  params.camera_motion = 0.0;
  params.kinect.disparity_noise_px = 0.2;
  const SyntheticScene scene(params);
  double sum_sq = 0.0;
  std::size_t n = 0;
  for (std::uint64_t i = 0; i < 3; ++i) {
    const RenderedFrame f = scene.render(i, 0);
    for (int v = 0; v < 480; v += 2)
      for (int u = 0; u < 640; u += 2) {
        const int mm = f.frame.depth.at<std::uint16_t>(v, u);
        if (mm == 0) continue;
        const double residual =
            kFocalBaseline / (mm / 1000.0) - kFocalBaseline / f.truth.ideal_depth.at<float>(v, u);
        sum_sq += residual * residual;
        ++n;
      }
  }
  const double expected = std::sqrt(0.2 * 0.2 + 0.125 * 0.125 / 12.0);
  EXPECT_NEAR(std::sqrt(sum_sq / n), expected, 0.1 * expected);
}

TEST(SyntheticScene, ProjectorShadowsFallLeftOfNearEdges) {
  // The projector sits at +x of the camera, so a near object hides from it a strip of the
  // background on the object's -x side. The camera (further left) sees that strip just left of
  // the object's left edge, fx * b * (1/z_near - 1/z_far) pixels wide; right edges are lit.
  // The width is exact for a vertical edge in front of a fronto-parallel background; round
  // objects (the projector sees another silhouette) and slanted backgrounds narrow it.
  const double fb = 525.0 * 0.075;
  int left_edges = 0, left_shadowed = 0, left_exact = 0, right_edges = 0, right_lit = 0;
  int unshadowed_left_lit = 0;
  SceneParams no_shadows;
  no_shadows.kinect.projector_shadows = false;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const RenderedFrame f = renderFrame(seed);
    const RenderedFrame g = renderFrame(seed, 0, no_shadows);
    const cv::Mat& ideal = f.truth.ideal_depth;
    for (int v = 0; v < 480; ++v)
      for (int u = 1; u < 638; ++u) {
        const double here = ideal.at<float>(v, u), right = ideal.at<float>(v, u + 1);
        if (here == 0 || right == 0) continue;
        if (here - right > 0.1) {  // background at u, near object starts at u + 1
          const double width = fb * (1.0 / right - 1.0 / here);
          if (width < 3.0 || u + 1 < width + 2) continue;
          ++left_edges;
          int run = 0;
          while (u - run >= 0 && f.frame.depth.at<std::uint16_t>(v, u - run) == 0) ++run;
          left_shadowed += run >= 0.5 * width;
          left_exact += std::abs(run - width) <= std::max(1.5, 0.25 * width);
          unshadowed_left_lit += g.frame.depth.at<std::uint16_t>(v, u) != 0;
        } else if (right - here > 0.1) {  // near object ends at u, background at u + 1
          ++right_edges;
          right_lit += f.frame.depth.at<std::uint16_t>(v, u + 1) != 0;
        }
      }
  }
  ASSERT_GT(left_edges, 200);
  ASSERT_GT(right_edges, 200);
  EXPECT_GT(static_cast<double>(left_shadowed) / left_edges, 0.95);
  EXPECT_GT(static_cast<double>(left_exact) / left_edges, 0.8);
  EXPECT_GT(static_cast<double>(right_lit) / right_edges, 0.8);
  // Without the projector model the same pixels have depth: the holes are the shadows.
  EXPECT_GT(static_cast<double>(unshadowed_left_lit) / left_edges, 0.8);
}

TEST(SyntheticScene, ValidPixelsAreNotAtGrazingIncidence) {
  const CameraIntrinsics k;
  const RenderedFrame f = renderFrame(5);
  const TruthFrame& t = f.truth;
  const double cos_limit = std::cos(80.0 * std::numbers::pi / 180.0) - 1e-4;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const std::uint16_t s = t.surface_labels.at<std::uint16_t>(v, u);
      if (s == 0 || surfaceById(t, s).kind != SurfaceKind::kPlane) continue;
      const Eigen::Vector3d ray = k.ray(u, v).normalized();
      ASSERT_GE(std::abs(surfaceById(t, s).plane.head<3>().dot(ray)), cos_limit)
          << surfaceById(t, s).name;
    }
}

TEST(SyntheticScene, ObjectBoxesContainTheirPixels) {
  const CameraIntrinsics k;
  for (std::uint64_t seed : {1, 6}) {
    const RenderedFrame f = renderFrame(seed);
    const TruthFrame& t = f.truth;
    std::vector<std::size_t> counts(t.objects.size() + 1, 0);
    for (int v = 0; v < 480; ++v)
      for (int u = 0; u < 640; ++u) {
        const std::uint16_t id = t.object_labels.at<std::uint16_t>(v, u);
        if (id == 0) continue;
        const TruthObject& o = t.objects.at(id - 1u);
        ++counts[id];
        ASSERT_TRUE(o.image_box.contains({u, v})) << o.name;
        const Eigen::Vector3d p = k.backproject(u, v, t.ideal_depth.at<float>(v, u));
        const Eigen::Vector3d local = o.rotation.transpose() * (p - o.center);
        ASSERT_TRUE((local.cwiseAbs() - o.size / 2).maxCoeff() < 1e-4)
            << o.name << " " << local.transpose();
      }
    for (const TruthObject& o : t.objects) {
      EXPECT_EQ(o.pixel_count, counts[o.id]) << o.name;
      EXPECT_EQ(o.image_box.empty(), o.pixel_count == 0) << o.name;
      EXPECT_TRUE(o.rotation.isUnitary(1e-9));
      for (int i = 0; i < 8; ++i) {
        const Eigen::Vector3d signs((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1);
        EXPECT_TRUE(
            o.corners[i].isApprox(o.center + o.rotation * signs.cwiseProduct(o.size / 2), 1e-9));
      }
    }
  }
}

TEST(SyntheticScene, RangeLimitsAreRespected) {
  for (const auto& [lo, hi] : {std::pair{0.5, 4.5}, std::pair{1.0, 2.5}}) {
    SceneParams params;
    params.kinect.min_range_m = lo;
    params.kinect.max_range_m = hi;
    const RenderedFrame f = renderFrame(1, 0, params);
    double min_mm = 1e9, max_mm = 0, min_ideal = 1e9, max_ideal = 0;
    for (int v = 0; v < 480; ++v)
      for (int u = 0; u < 640; ++u) {
        const int mm = f.frame.depth.at<std::uint16_t>(v, u);
        const float ideal = f.truth.ideal_depth.at<float>(v, u);
        if (mm != 0) min_mm = std::min<double>(min_mm, mm), max_mm = std::max<double>(max_mm, mm);
        if (ideal != 0)
          min_ideal = std::min<double>(min_ideal, ideal),
          max_ideal = std::max<double>(max_ideal, ideal);
      }
    EXPECT_GE(min_mm, lo * 1000);
    EXPECT_LE(max_mm, hi * 1000);
    EXPECT_GE(min_ideal, lo);
    EXPECT_LE(max_ideal, hi);
  }
}

TEST(SyntheticScene, BowlViewClassThresholds) {
  EXPECT_EQ(bowlViewClass(5.0), "side");
  EXPECT_EQ(bowlViewClass(19.9), "side");
  EXPECT_EQ(bowlViewClass(20.0), "middle");
  EXPECT_EQ(bowlViewClass(60.0), "middle");
  EXPECT_EQ(bowlViewClass(60.1), "top");
}

/// All bowls of seeds 1..n; checks each bowl's truth on the way.
std::vector<TruthObject> bowlsOf(SceneParams params, int seeds) {
  std::vector<TruthObject> bowls;
  for (int seed = 1; seed <= seeds; ++seed) {
    const RenderedFrame f = renderFrame(seed, 0, params);
    const Eigen::Vector3d up = cameraUp(f.truth);
    for (const TruthObject& o : f.truth.objects) {
      if (o.kind != "bowl") continue;
      EXPECT_GE(o.rim_radius_m, 0.06);
      EXPECT_LE(o.rim_radius_m, 0.15);
      EXPECT_GT(o.shell_thickness_m, 0.0);
      EXPECT_NEAR(o.axis.dot(up), o.upright ? 1.0 : -1.0, 1e-9);
      const double elevation =
          std::asin(up.dot(-o.rim_center.normalized())) * 180 / std::numbers::pi;
      EXPECT_NEAR(o.view_elevation_deg, elevation, 1e-6);
      EXPECT_EQ(o.view_class, bowlViewClass(elevation));
      bowls.push_back(o);
    }
  }
  return bowls;
}

TEST(SyntheticScene, BowlViewClassFollowsTheCameraElevation) {
  SceneParams steep;  // high camera right at the table
  steep.camera_height_min_m = steep.camera_height_max_m = 1.4;
  steep.table_distance_min_m = 0.8;
  steep.table_distance_max_m = 0.85;
  steep.bowls_min = steep.bowls_max = 3;
  SceneParams flat;  // low camera far from the table
  flat.camera_height_min_m = 0.8;
  flat.camera_height_max_m = 0.85;
  flat.table_distance_min_m = 2.0;
  flat.table_distance_max_m = 2.5;
  flat.min_table_elevation_deg = 2.0;
  flat.bowls_min = flat.bowls_max = 3;
  std::map<std::string, int> classes;
  for (const SceneParams& params : {steep, flat, SceneParams{}}) {
    for (const TruthObject& bowl : bowlsOf(params, 6)) ++classes[bowl.view_class];
  }
  EXPECT_GT(classes["top"], 0);
  EXPECT_GT(classes["middle"], 0);
  EXPECT_GT(classes["side"], 0);
}

TEST(SyntheticScene, BowlsSeenFromAboveShowMostlyTheirInside) {
  SceneParams params;
  params.bowls_min = params.bowls_max = 3;
  params.kinect.projector_shadows = false;
  int checked = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const RenderedFrame f = renderFrame(seed, 0, params);
    for (const TruthObject& bowl : f.truth.objects) {
      if (bowl.kind != "bowl" || bowl.pixel_count < 400) continue;
      std::size_t inner = 0, outer = 0;
      for (const TruthSurface& s : f.truth.surfaces) {
        if (s.object_id != bowl.id) continue;
        if (s.name.ends_with("_inner")) inner = s.pixel_count;
        if (s.name.ends_with("_outer")) outer = s.pixel_count;
      }
      SCOPED_TRACE(bowl.name + " elevation " + std::to_string(bowl.view_elevation_deg));
      if (bowl.view_elevation_deg > 35) {
        EXPECT_GT(inner, outer);
      }
      EXPECT_GT(inner + outer, 0u);
      ++checked;
    }
  }
  EXPECT_GT(checked, 5);
}

// visible_fraction against the pixels themselves: with a sensor that reads every pixel and
// nothing on the table but one bowl, a bowl inside the image, upright or upside down, is seen
// whole (silhouette area and pixel count within 10%; measured 0.91-1.01, 14 of 16 within 0.8%);
// the same scene with half of the readings dropped at random halves it. (Moving the image border
// through the bowl instead would change the layout: the scene draws it from the intrinsics.)
TEST(SyntheticScene, BowlVisibleFractionFollowsWhatTheSensorSees) {
  SceneParams params;
  params.render_colour = false;
  params.boxes_on_table_min = params.boxes_on_table_max = 0;
  params.floor_box_probability = 0.0;
  params.cups_min = params.cups_max = 0;
  params.tins_min = params.tins_max = 0;
  params.balls_min = params.balls_max = 0;
  params.bowls_min = params.bowls_max = 1;
  params.kinect.dropout_rate = 0.0;
  params.kinect.projector_shadows = false;
  params.kinect.max_incidence_deg = 90.0;
  params.camera_motion = 0.0;
  int whole = 0, halved = 0;
  for (const double upside_down : {0.0, 1.0}) {
    params.bowl_upside_down_probability = upside_down;
    for (std::uint64_t seed = 1; seed <= 8; ++seed) {
      params.seed = seed;
      const RenderedFrame f = SyntheticScene(params).render(0, 0);
      for (const TruthObject& bowl : f.truth.objects) {
        if (bowl.kind != "bowl") continue;
        const cv::Rect inner(5, 5, params.intrinsics.width - 10, params.intrinsics.height - 10);
        if (bowl.pixel_count < 300 || (bowl.image_box & inner) != bowl.image_box) continue;
        SCOPED_TRACE(bowl.name + " seed " + std::to_string(seed) +
                     (bowl.upright ? " upright" : " upside down"));
        EXPECT_GT(bowl.visible_fraction, 0.9);
        EXPECT_LT(bowl.visible_fraction, 1.05);
        ++whole;

        // The same scene with a sensor that drops every other reading at random.
        SceneParams cut = params;
        cut.kinect.dropout_rate = 0.5;
        const RenderedFrame g = SyntheticScene(cut).render(0, 0);
        const TruthObject& same = g.truth.objects.at(bowl.id - 1u);
        ASSERT_EQ(same.name, bowl.name);
        ASSERT_LT((same.rim_center - bowl.rim_center).norm(), 1e-9) << "the layout changed";
        // Binomial: with >= 300 pixels the dropped share has a sigma under 0.03.
        EXPECT_NEAR(same.visible_fraction, 0.5 * bowl.visible_fraction, 0.1);
        ++halved;
        std::printf("%s seed %d %s: visible %.3f, %.3f with half of the readings dropped\n",
                    bowl.name.c_str(), static_cast<int>(seed),
                    bowl.upright ? "upright" : "upside down", bowl.visible_fraction,
                    same.visible_fraction);
      }
    }
  }
  EXPECT_GE(whole, 8);
  EXPECT_EQ(halved, whole);
}

TEST(SyntheticScene, RejectsImpossibleParams) {
  SceneParams bad_range;
  bad_range.bowls_min = 3;
  bad_range.bowls_max = 1;
  EXPECT_THROW(SyntheticScene{bad_range}, std::invalid_argument);
  SceneParams bad_rate;
  bad_rate.frame_rate_hz = 0;
  EXPECT_THROW(SyntheticScene{bad_rate}, std::invalid_argument);
  SceneParams unreachable;  // camera below the lowest table
  unreachable.camera_height_min_m = unreachable.camera_height_max_m = 0.5;
  EXPECT_THROW(SyntheticScene{unreachable}, std::invalid_argument);
}

}  // namespace
}  // namespace shapesense::synthetic
