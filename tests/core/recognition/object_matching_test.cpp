// Shape features and object matching against the synthetic renderer's truth: an object taught
// from one frame is found in another frame of the same scene, whose camera moved; the truth
// motion is known from both frames' camera poses.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/driver/ply_cloud.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/recognition_eval.h"
#include "two_views.h"

namespace shapesense {
namespace {

// Error of an estimated model-to-camera motion against the truth, at the model's centre, as
// the recognition evaluation judges it (symmetric objects: the least over their symmetries).
cv::Mat objectMask(const synthetic::TruthFrame& truth, std::uint16_t object_id) {
  cv::Mat mask = truth.object_labels == object_id;
  return mask;
}

TEST(ShapeFeatures, MoveWithTheSurface) {
  synthetic::SceneParams params;
  params.seed = 11;
  params.camera_motion = 0.0;
  const auto rendered = synthetic::SyntheticScene(params).render(0, 0);
  SurfaceCloudParams cloud_params;
  cloud_params.voxel_m = 1e-4f;  // no thinning: both clouds hold the same points
  const SurfaceCloud cloud =
      surfaceCloudFromDepth(rendered.frame.depth, rendered.frame.intrinsics, {}, cloud_params);
  Eigen::Isometry3f motion = Eigen::Isometry3f::Identity();
  motion.linear() =
      Eigen::AngleAxisf(0.6f, Eigen::Vector3f(0.3f, 1.0f, 0.2f).normalized()).toRotationMatrix();
  motion.translation() = Eigen::Vector3f(0.4f, -0.2f, 0.5f);
  SurfaceCloud moved;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    moved.points.push_back(motion * cloud.points[i]);
    moved.normals.push_back(motion.linear() * cloud.normals[i]);
  }
  ShapeFeatureParams feature_params;
  const auto features = detectShapeFeatures(cloud, feature_params);
  const auto moved_features =
      detectShapeFeatures(moved, feature_params, motion * Eigen::Vector3f::Zero());
  ASSERT_GT(features.size(), 100u);
  // The same points, moved rigidly: the same interest points, local frames and descriptors
  // (up to float rounding), so each feature has its twin among those at its point. Not every
  // one: the histogram whose peaks give a point's frames has its bins where the cloud's
  // coordinates put them, so a second peak near orientation_peak_ratio may come or go.
  int twins = 0;
  for (const auto& f : features) {
    const bool twinned = std::any_of(moved_features.begin(), moved_features.end(), [&](auto& g) {
      const Eigen::Matrix3f frame_difference = (motion.linear() * f.frame).transpose() * g.frame;
      return (motion * f.position - g.position).norm() < 1e-4f &&
             (frame_difference - Eigen::Matrix3f::Identity()).norm() < 1e-2f &&
             descriptorDistance2(f, g) < 1e-4f;
    });
    twins += twinned ? 1 : 0;
  }
  EXPECT_GE(twins, static_cast<int>(0.9 * static_cast<double>(features.size())))
      << features.size() << " features, " << moved_features.size() << " after the motion";
}

TEST(ObjectMatchingQuality, FindsATaughtBoxInALaterFrame) {
  int found = 0, tried = 0;
  for (std::uint64_t seed = 21; seed < 27; ++seed) {
    const auto [teach, later, truth] = testing::twoViews(seed, 150);
    const SceneSurface later_surface(later.frame.depth, later.frame.intrinsics);
    for (const auto& object : teach.truth.objects) {
      if (object.kind != "box" && object.kind != "cup" && object.kind != "tin") continue;
      if (object.pixel_count < 1500) continue;
      ObjectModel model;
      try {
        model = teachObjectModel(object.name, teach.frame.depth, teach.frame.intrinsics,
                                 objectMask(teach.truth, object.id));
      } catch (const std::invalid_argument& e) {
        std::printf("seed %lu %s: %s\n", seed, object.name.c_str(), e.what());
        continue;
      }
      ++tried;
      const auto detection = findObject(model, later_surface);
      if (!detection) {
        std::printf("seed %lu %s (%zu px, %zu features): not found\n", seed, object.name.c_str(),
                    object.pixel_count, model.features.size());
        continue;
      }
      const eval::PoseErrorDeg error =
          testing::taughtObjectError(detection->camera_from_model, truth, model.box.centre, object);
      std::printf(
          "seed %lu %s (%zu px, %zu features): score %.2f inliers %d error %.1f mm %.2f deg\n",
          seed, object.name.c_str(), object.pixel_count, model.features.size(), detection->score,
          detection->feature_inliers, 1e3 * error.translation_m, error.rotation_deg);
      if (testing::withinRecallTolerance(error)) ++found;
    }
  }
  std::printf("found %d of %d\n", found, tried);
  // Requirement (issue 22): recall >= 0.90 at <= 1 cm and 5 deg (met on these later frames of
  // the teaching scenes, where the camera moved a little; not on the test split's other views,
  // RecognitionQuality).
  EXPECT_GE(tried, 20);
  EXPECT_GE(found, 0.9 * tried);
}

// followObject: from a pose near the truth (a previous frame's), ICP lands on the truth; from
// one farther than ICP reaches, it reports nothing rather than a wrong pose.
TEST(ObjectMatching, FollowsAnObjectFromANearbyPose) {
  const auto [teach, later, truth] = testing::twoViews(21, 6);
  const SceneSurface later_surface(later.frame.depth, later.frame.intrinsics);
  int tried = 0;
  for (const auto& object : teach.truth.objects) {
    if ((object.kind != "box" && object.kind != "tin") || object.pixel_count < 3000) continue;
    const ObjectModel model = teachObjectModel(
        object.name, teach.frame.depth, teach.frame.intrinsics, objectMask(teach.truth, object.id));
    ++tried;
    // 1 cm and 3 deg off at the object's centre: a robot's sensor turning 30 deg a second,
    // seen at 10 frames a second (followObject reaches 3 cm for most of these objects).
    const Eigen::Isometry3f right = truth.cast<float>();
    const Eigen::Vector3f centre = right * model.box.centre;
    Eigen::Isometry3f near = right;
    near.linear() = Eigen::AngleAxisf(3.0f * static_cast<float>(M_PI) / 180.0f,
                                      Eigen::Vector3f(1.0f, 2.0f, 0.5f).normalized())
                        .toRotationMatrix() *
                    right.linear();
    near.translation() =
        centre + Eigen::Vector3f(0.006f, -0.006f, 0.0053f) - near.linear() * model.box.centre;
    const auto followed = followObject(model, later_surface, near);
    ASSERT_TRUE(followed.has_value()) << object.name;
    const eval::PoseErrorDeg error =
        testing::taughtObjectError(followed->camera_from_model, truth, model.box.centre, object);
    EXPECT_LE(error.translation_m, 0.005) << object.name;
    EXPECT_LE(error.rotation_deg, 2.0) << object.name;
    EXPECT_EQ(followed->feature_inliers, 0);
    // The same from the surface of the region it reads alone.
    const cv::Rect region = followObjectRegion(model, near, later.frame.intrinsics);
    cv::Mat mask = cv::Mat::zeros(later.frame.depth.size(), CV_8UC1);
    mask(region).setTo(255);
    EXPECT_LT(region.area(), later.frame.depth.total() / 2);
    const SceneSurface around(later.frame.depth, later.frame.intrinsics, {}, mask);
    const auto followed_around = followObject(model, around, near);
    ASSERT_TRUE(followed_around.has_value()) << object.name;
    EXPECT_LT((followed_around->camera_from_model.translation() -
               followed->camera_from_model.translation())
                  .norm(),
              0.001f)
        << object.name;

    Eigen::Isometry3f far_away = Eigen::Isometry3f::Identity();
    far_away.translation() = Eigen::Vector3f(0.4f, 0.0f, 0.0f);
    const auto lost = followObject(model, later_surface, far_away * truth.cast<float>());
    if (lost) {
      const eval::PoseErrorDeg far_error =
          testing::taughtObjectError(lost->camera_from_model, truth, model.box.centre, object);
      EXPECT_LE(far_error.translation_m, 0.01) << object.name << ": a wrong pose";
    }
  }
  EXPECT_GE(tried, 2);
}

// checkObjectPose tells what the check decides by: the truth pose passes, and one moved well
// off the object fails, saying which rule; verifyObjectPose agrees with it.
TEST(ObjectMatching, ThePoseCheckSaysWhichRuleAPoseFails) {
  const auto [teach, later, truth] = testing::twoViews(21, 6);
  const SceneSurface later_surface(later.frame.depth, later.frame.intrinsics);
  int tried = 0;
  for (const auto& object : teach.truth.objects) {
    if (object.kind != "box" || object.pixel_count < 3000) continue;
    const ObjectModel model = teachObjectModel(
        object.name, teach.frame.depth, teach.frame.intrinsics, objectMask(teach.truth, object.id));
    ++tried;
    const PoseCheck right = checkObjectPose(model, later_surface, truth.cast<float>());
    EXPECT_TRUE(right.failed.empty()) << object.name << ": " << right.failed;
    EXPECT_GE(right.score, 0.95f) << object.name;
    EXPECT_TRUE(verifyObjectPose(model, later_surface, truth.cast<float>()).has_value());
    // 8 cm towards the camera: in front of everything the depth shows there.
    Eigen::Isometry3f off = Eigen::Isometry3f::Identity();
    off.translation() = -0.08f * (truth.cast<float>() * model.box.centre).normalized();
    const PoseCheck wrong = checkObjectPose(model, later_surface, off * truth.cast<float>());
    EXPECT_EQ(wrong.failed.rfind("score ", 0), 0u) << object.name << ": " << wrong.failed;
    EXPECT_LT(wrong.score, 0.95f) << object.name;
    EXPECT_GT(wrong.contradicted, wrong.confirmed) << object.name;
    EXPECT_FALSE(verifyObjectPose(model, later_surface, off * truth.cast<float>()).has_value());
    // Behind the camera: nothing to check it by.
    Eigen::Isometry3f behind = Eigen::Isometry3f::Identity();
    behind.translation() = Eigen::Vector3f(0.0f, 0.0f, -10.0f);
    const PoseCheck unseen = checkObjectPose(model, later_surface, behind * truth.cast<float>());
    EXPECT_EQ(unseen.failed.rfind("no model point", 0), 0u) << unseen.failed;
    EXPECT_EQ(unseen.confirmed + unseen.contradicted, 0);
  }
  EXPECT_GE(tried, 1);
}

// Models taught in some scenes, looked for in scenes of other seeds, whose boxes and tins have
// other sizes: every detection is false.
TEST(ObjectMatchingQuality, FindsNoTaughtObjectInScenesWithoutIt) {
  std::vector<ObjectModel> models;
  for (std::uint64_t seed = 21; seed < 24; ++seed) {
    const auto teach = synthetic::SyntheticScene([&] {
                         synthetic::SceneParams p;
                         p.seed = seed;
                         return p;
                       }())
                           .render(0, 0);
    for (const auto& object : teach.truth.objects) {
      if ((object.kind != "box" && object.kind != "tin") || object.pixel_count < 1500) continue;
      try {
        models.push_back(teachObjectModel(object.name, teach.frame.depth, teach.frame.intrinsics,
                                          objectMask(teach.truth, object.id)));
      } catch (const std::invalid_argument&) {
      }
    }
  }
  ASSERT_GE(models.size(), 8u);
  int frames = 0, detections = 0;
  for (std::uint64_t seed = 41; seed < 47; ++seed) {
    synthetic::SceneParams p;
    p.seed = seed;
    const auto rendered = synthetic::SyntheticScene(p).render(0, 0);
    const SceneSurface scene(rendered.frame.depth, rendered.frame.intrinsics);
    ++frames;
    for (const auto& model : models) {
      const auto detection = findObject(model, scene);
      if (!detection) continue;
      ++detections;
      std::printf("seed %lu: %s found, score %.2f, %d inliers\n", seed, model.name.c_str(),
                  detection->score, detection->feature_inliers);
    }
  }
  std::printf("%d false detections of %zu models in %d frames\n", detections, models.size(),
              frames);
  // Requirement (issue 22): <= 0.1 false detections per frame for five taught objects, here
  // 0.1 * frames * models / 5 = 1.3. Regression record: 2 when first measured (both on one
  // box of about the same size as the two models).
  EXPECT_LE(detections, 2);
}

// Distance from `p` to the solid box `object` (0 inside).
double distanceToBox(const Eigen::Vector3f& p, const synthetic::TruthObject& object) {
  const Eigen::Vector3d local = object.rotation.transpose() * (p.cast<double>() - object.center);
  const Eigen::Vector3d outside = (local.cwiseAbs() - 0.5 * object.size).cwiseMax(0.0);
  return outside.norm();
}

// The outline probes mark where the object ends, so they must lie clear of the whole object,
// the sides the taught view does not see included: a probe on or near the object reads as
// "the object goes on" in another view and refuses its right pose.
TEST(ObjectModel, OutlineProbesLieClearOfTheWholeObject) {
  const ObjectModelParams params;
  std::vector<double> clearance;
  int boxes = 0;
  for (std::uint64_t seed = 21; seed < 25; ++seed) {
    synthetic::SceneParams scene_params;
    scene_params.seed = seed;
    const auto teach = synthetic::SyntheticScene(scene_params).render(0, 0);
    for (const auto& object : teach.truth.objects) {
      if (object.kind != "box" || object.pixel_count < 1500) continue;
      const ObjectModel model =
          teachObjectModel(object.name, teach.frame.depth, teach.frame.intrinsics,
                           objectMask(teach.truth, object.id), params);
      ++boxes;
      EXPECT_GE(model.outline_probes.size(), 30u) << object.name << ", seed " << seed;
      for (const Eigen::Vector3f& probe : model.outline_probes)
        clearance.push_back(distanceToBox(probe, object));
    }
  }
  ASSERT_GE(boxes, 6);
  std::sort(clearance.begin(), clearance.end());
  const double low = clearance[clearance.size() / 100];
  std::printf(
      "%d boxes, %zu probes: clearance from the box 1st percentile %.1f mm, median %.1f mm\n",
      boxes, clearance.size(), 1e3 * low, 1e3 * clearance[clearance.size() / 2]);
  // Probes sit outline_probe_offset_m (1.25 cm) out, at depths read from the sensor, whose
  // noise at these ranges (1-2 m) is a few millimetres.
  EXPECT_GE(low, 0.5 * params.outline_probe_offset_m);
}

// A model from a point cloud file: the object's points written as PLY (without normals, as a
// scanner might give them), read back, and found in a later frame.
TEST(ObjectMatching, FindsAnObjectModelledFromAPlyFile) {
  const auto [teach, later, truth] = testing::twoViews(25, 150);
  const synthetic::TruthObject* box = nullptr;
  for (const auto& object : teach.truth.objects)
    if (object.name == "box1") box = &object;
  ASSERT_NE(box, nullptr);
  PointCloudFile file;
  const auto& k = teach.frame.intrinsics;
  for (int v = 0; v < teach.frame.depth.rows; ++v)
    for (int u = 0; u < teach.frame.depth.cols; ++u) {
      const std::uint16_t z = teach.frame.depth.at<std::uint16_t>(v, u);
      if (z == 0 || teach.truth.object_labels.at<std::uint16_t>(v, u) != box->id) continue;
      file.points.push_back(k.backproject(u, v, 1e-3 * z).cast<float>());
    }
  const auto path = std::filesystem::temp_directory_path() / "shapesense_box1.ply";
  savePlyCloud(path, file);
  const PointCloudFile loaded = loadPlyCloud(path);
  std::filesystem::remove(path);
  const ObjectModel model =
      objectModelFromSurface("box1", surfaceCloudFromPoints(loaded.points, loaded.normals));
  EXPECT_TRUE(model.outline_probes.empty());
  const auto detection = findObject(model, SceneSurface(later.frame.depth, later.frame.intrinsics));
  ASSERT_TRUE(detection.has_value());
  const eval::PoseErrorDeg error =
      testing::taughtObjectError(detection->camera_from_model, truth, model.box.centre, *box);
  EXPECT_LE(error.translation_m, 0.01);
  EXPECT_LE(error.rotation_deg, 5.0);
}

}  // namespace
}  // namespace shapesense
