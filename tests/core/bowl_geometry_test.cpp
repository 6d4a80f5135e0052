// The 3D bowl check (measureBowlGeometry) against the synthetic renderer's ground truth, on the
// truth boxes of the objects: upright bowls seen whole are bowls with the right rim, and the
// look-alikes the classifier confuses with them (upside-down bowls, tins, balls, cups) are not.
// Seeds 777000+ are used by no other test, by training or by the evaluation sets.
#include <cstdio>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shapesense/core/bowl_geometry.h"
#include "shapesense/core/planes.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

// Requirements: an operator must see the bowls that are in view and must not be shown the
// round things that are not.
constexpr double kMinBowlsKept = 0.95;
constexpr double kMinLookAlikesRejected = 0.95;
constexpr double kRimTolerance = 0.15;  // relative error of the measured rim diameter

synthetic::SceneParams sceneParams(int k) {
  synthetic::SceneParams p;
  p.seed = 777000ULL + static_cast<std::uint64_t>(k);
  p.render_colour = false;
  if (k % 2 == 1) {  // a raised camera: the table-top views of the real frames
    p.camera_height_min_m = 1.3;
    p.camera_height_max_m = 1.6;
    p.table_distance_min_m = 1.1;
    p.table_distance_max_m = 1.8;
    p.min_table_elevation_deg = 17.0;
  }
  return p;
}

/// Seen whole: not hidden, not cut by the image border (the rim's width is then measurable).
bool seenWhole(const synthetic::TruthObject& o, const cv::Size& image) {
  const cv::Rect inner(2, 2, image.width - 4, image.height - 4);
  return o.visible_fraction >= 0.85 && (o.image_box & inner) == o.image_box;
}

TEST(BowlGeometry, UprightBowlsSeenWholeAreBowlsWithTheirRim) {
  HoughPlaneDetector plane_detector;
  int bowls = 0, kept = 0, rim_ok = 0;
  for (int k = 0; k < 24; ++k) {
    const synthetic::SyntheticScene scene(sceneParams(k));
    const auto r = scene.render(0, 0);
    const auto planes = plane_detector.detect(r.frame.depth, r.frame.intrinsics);
    for (const auto& o : r.truth.objects) {
      if (o.kind != "bowl" || !o.upright || !seenWhole(o, r.frame.depth.size())) continue;
      ++bowls;
      const auto measured =
          measureBowlGeometry(r.frame.depth, r.frame.intrinsics, o.image_box, planes);
      const auto* g = std::get_if<BowlGeometry>(&measured);
      if (g == nullptr) {
        for (const auto& sf : r.truth.surfaces)
          if (sf.name == "table_top") std::printf("truth table %.3f %.3f %.3f %.3f\n", sf.plane[0], sf.plane[1], sf.plane[2], sf.plane[3]);
        for (const auto& pl : planes.planes) std::printf("  plane %d n %.3f %.3f %.3f d %.3f inliers %zu\n", pl.id, pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.d, pl.inliers);
        if (getenv("BOWLDBG")) { cv::Mat img; r.frame.depth.convertTo(img, CV_8U, 255.0/4000); cv::rectangle(img, o.image_box, 255); cv::imwrite("/tmp/dbg_" + std::to_string(k) + o.name + ".png", img); cv::Mat lab; planes.labels.convertTo(lab, CV_8U, 20); cv::rectangle(lab, o.image_box, 255); cv::imwrite("/tmp/dbgl_" + std::to_string(k) + o.name + ".png", lab);}
        std::printf("seed %d %s %s view %.0f deg rim %.1f cm: rejected, %s\n", k, o.name.c_str(),
                    o.view_class.c_str(), o.view_elevation_deg, 200 * o.rim_radius_m,
                    toString(std::get<BowlGeometryRejection>(measured)).c_str());
        continue;
      }
      ++kept;
      const double truth = 2 * o.rim_radius_m;
      const bool ok = std::abs(g->rim_diameter_m - truth) <= kRimTolerance * truth;
      rim_ok += ok;
      EXPECT_TRUE(ok) << "seed " << k << " " << o.name << ": rim " << g->rim_diameter_m
                      << " m, truth " << truth << " m";
      EXPECT_NE(g->support_plane_id, 0);
    }
  }
  std::printf("upright bowls seen whole: %d, kept %d, rim within %.0f%%: %d\n", bowls, kept,
              100 * kRimTolerance, rim_ok);
  ASSERT_GE(bowls, 20);
  EXPECT_GE(kept, kMinBowlsKept * bowls);
}

TEST(BowlGeometry, UpsideDownBowlsTinsBallsAndCupsAreNotBowls) {
  HoughPlaneDetector plane_detector;
  int look_alikes = 0, rejected = 0;
  for (int k = 0; k < 24; ++k) {
    auto p = sceneParams(k);
    p.bowl_upside_down_probability = 1.0;
    p.tins_min = 1;
    p.balls_min = 1;
    p.cups_min = 1;
    const synthetic::SyntheticScene scene(p);
    const auto r = scene.render(0, 0);
    const auto planes = plane_detector.detect(r.frame.depth, r.frame.intrinsics);
    for (const auto& o : r.truth.objects) {
      const bool look_alike = (o.kind == "bowl" && !o.upright) || o.kind == "tin" ||
                              o.kind == "ball" || o.kind == "cup";
      if (!look_alike || o.image_box.width < 20 || o.pixel_count < 300) continue;
      ++look_alikes;
      const auto measured =
          measureBowlGeometry(r.frame.depth, r.frame.intrinsics, o.image_box, planes);
      if (std::holds_alternative<BowlGeometryRejection>(measured)) {
        ++rejected;
        continue;
      }
      const auto& g = std::get<BowlGeometry>(measured);
      std::printf("seed %d %s (%s%s): taken for a bowl, rim %.1f cm height %.1f cm widening %.2f\n",
                  k, o.name.c_str(), o.kind.c_str(), o.upright ? "" : ", upside down",
                  100 * g.rim_diameter_m, 100 * g.height_m, g.rim_to_foot_width);
    }
  }
  std::printf("look-alikes: %d, rejected %d\n", look_alikes, rejected);
  ASSERT_GE(look_alikes, 40);
  EXPECT_GE(rejected, kMinLookAlikesRejected * look_alikes);
}

// Nothing to stand on (no plane detection), an empty box, a box off the image: a clear
// rejection, never a crash.
TEST(BowlGeometry, DegenerateInputsAreRejected) {
  const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(1000));
  const CameraIntrinsics k;
  const PlaneDetection none;
  EXPECT_EQ(std::get<BowlGeometryRejection>(
                measureBowlGeometry(depth, k, cv::Rect(100, 100, 50, 40), none)),
            BowlGeometryRejection::kNoSupport);
  EXPECT_EQ(std::get<BowlGeometryRejection>(measureBowlGeometry(depth, k, cv::Rect(), none)),
            BowlGeometryRejection::kNoObject);
  EXPECT_EQ(std::get<BowlGeometryRejection>(
                measureBowlGeometry(depth, k, cv::Rect(700, 500, 50, 40), none)),
            BowlGeometryRejection::kNoObject);
  const cv::Mat empty(480, 640, CV_16UC1, cv::Scalar(0));
  EXPECT_EQ(std::get<BowlGeometryRejection>(
                measureBowlGeometry(empty, k, cv::Rect(100, 100, 50, 40), none)),
            BowlGeometryRejection::kNoObject);
}

}  // namespace
}  // namespace shapesense
