// Taught objects followed over a frame sequence, against the synthetic renderer's truth: the
// camera moves through scenes whose boxes and tins were taught from their first frame.

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <vector>

#include "shapesense/core/tracking/taught_object_tracker.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/recognition_eval.h"
#include "two_views.h"

namespace shapesense {
namespace {

struct TaughtScene {
  std::unique_ptr<synthetic::SyntheticScene> scene;
  std::vector<std::shared_ptr<const ObjectModel>> models;
  std::vector<synthetic::TruthObject> taught;  ///< as seen in frame 0, one per model
  Eigen::Isometry3d world_from_teaching_camera;
};

// The boxes and tins of frame 0 of scene `seed` (at least `min_pixels` of them in view), taught.
TaughtScene teachScene(std::uint64_t seed, std::size_t min_pixels = 3000) {
  synthetic::SceneParams params;
  params.seed = seed;
  params.camera_motion = 1.5;
  TaughtScene out;
  out.scene = std::make_unique<synthetic::SyntheticScene>(params);
  const auto teach = out.scene->render(0, 0);
  out.world_from_teaching_camera = teach.truth.world_from_camera;
  for (const auto& object : teach.truth.objects) {
    if ((object.kind != "box" && object.kind != "tin") || object.pixel_count < min_pixels) continue;
    try {
      out.models.push_back(std::make_shared<const ObjectModel>(
          teachObjectModel(object.name + "_" + std::to_string(seed), teach.frame.depth,
                           teach.frame.intrinsics, teach.truth.object_labels == object.id)));
      out.taught.push_back(object);
    } catch (const std::invalid_argument&) {
      // Too little surface or shape to teach: not one of this test's objects.
    }
  }
  return out;
}

const synthetic::TruthObject* inFrame(const synthetic::TruthFrame& truth,
                                      const synthetic::TruthObject& taught) {
  for (const auto& object : truth.objects)
    if (object.id == taught.id) return &object;
  return nullptr;
}

// The tolerance of issue 22's recall: 1 cm and 5 deg at the model's centre.
bool poseIsRight(const ObjectDetection& detection, const ObjectModel& model,
                 const synthetic::TruthObject& object, const Eigen::Isometry3d& truth_motion) {
  return testing::withinRecallTolerance(testing::taughtObjectError(
      detection.camera_from_model, truth_motion, model.box.centre, object));
}

// Every third frame of two seconds of motion at 30 fps (10 fps, as a busy pipeline processes
// them). The objects are searched for one a frame at first (searches_per_frame 1), so recall
// counts the frames after each has had its first search.
TEST(TaughtObjectTrackerQuality, FollowsTaughtObjectsWhileTheCameraMoves) {
  int visible = 0, found = 0, wrong = 0, frames = 0, frames_without_search = 0;
  double described_without_search = 0.0;
  for (std::uint64_t seed = 21; seed <= 26; ++seed) {
    const TaughtScene taught = teachScene(seed);
    TaughtObjectTracker tracker;
    for (std::uint64_t index = 3; index <= 60; index += 3) {
      const auto later = taught.scene->render(index, 0);
      const Eigen::Isometry3d truth_motion =
          later.truth.world_from_camera.inverse() * taught.world_from_teaching_camera;
      const auto detections =
          tracker.update(later.frame.depth, later.frame.intrinsics, taught.models);
      const bool warming_up = index / 3 <= taught.models.size();
      ++frames;
      if (tracker.lastSearches() == 0) {
        ++frames_without_search;
        described_without_search += tracker.lastDescribedShare();
      }
      for (std::size_t m = 0; m < taught.models.size(); ++m) {
        const ObjectModel& model = *taught.models[m];
        const synthetic::TruthObject* object = inFrame(later.truth, taught.taught[m]);
        const ObjectDetection* detection = nullptr;
        for (const auto& d : detections)
          if (d.name == model.name) detection = &d;
        // Issue 22's condition: at least half of the object in view.
        const bool in_view = object && 2 * object->pixel_count >= taught.taught[m].pixel_count;
        if (in_view && !warming_up) ++visible;
        if (!detection) continue;
        if (object && poseIsRight(*detection, model, *object, truth_motion)) {
          found += in_view && !warming_up ? 1 : 0;
        } else {
          ++wrong;
          const eval::PoseErrorDeg error = testing::taughtObjectError(
              detection->camera_from_model, truth_motion, model.box.centre, taught.taught[m]);
          std::printf("seed %lu frame %lu %s: a wrong pose (%.1f mm, %.1f deg; %zu px of %zu)\n",
                      seed, index, model.name.c_str(), 1e3 * error.translation_m,
                      error.rotation_deg, object ? object->pixel_count : 0,
                      taught.taught[m].pixel_count);
        }
      }
    }
  }
  const double described_share = described_without_search / std::max(1, frames_without_search);
  std::printf(
      "%d of %d objects in view found, %d wrong poses; %d of %d frames without a search, "
      "describing %.2f of the image\n",
      found, visible, wrong, frames_without_search, frames, described_share);
  ASSERT_GE(visible, 150);
  // Requirements (issue 22): recall >= 0.90 at 1 cm and 5 deg; at most 0.1 false detections
  // a frame.
  EXPECT_GE(found, 0.9 * visible);
  EXPECT_LE(wrong, 0.1 * frames);
  // What following is for: once found, objects in view are not searched for again. The first
  // frames search (one object a frame), objects that leave the view are searched for in turn.
  EXPECT_GE(frames_without_search, frames / 2);
  // ...and describe only the image around them.
  EXPECT_LT(described_share, 0.8);
}

TEST(TaughtObjectTracker, SearchesForObjectsOutOfViewInTurn) {
  // Models of other scenes: never in view, so never followed, and searched for one a frame.
  std::vector<std::shared_ptr<const ObjectModel>> absent;
  for (std::uint64_t seed : {31, 32}) {
    for (auto& model : teachScene(seed).models) absent.push_back(model);
  }
  ASSERT_GE(absent.size(), 3u);
  const TaughtScene here = teachScene(21);
  TaughtObjectTrackerParams tracker_params;
  tracker_params.searches_per_frame = 1;
  TaughtObjectTracker tracker(tracker_params);
  int searches = 0;
  for (std::uint64_t index = 0; index < 2 * absent.size(); ++index) {
    const auto frame = here.scene->render(index, 0);
    const auto detections = tracker.update(frame.frame.depth, frame.frame.intrinsics, absent);
    EXPECT_TRUE(detections.empty()) << "frame " << index << ": " << detections.front().name;
    EXPECT_EQ(tracker.lastSearches(), 1);
    searches += tracker.lastSearches();
  }
  EXPECT_EQ(searches, static_cast<int>(2 * absent.size()));

  TaughtObjectTrackerParams all_at_once_params;
  all_at_once_params.searches_per_frame = 0;
  TaughtObjectTracker all_at_once(all_at_once_params);
  const auto frame = here.scene->render(0, 0);
  all_at_once.update(frame.frame.depth, frame.frame.intrinsics, absent);
  EXPECT_EQ(all_at_once.lastSearches(), static_cast<int>(absent.size()));
}

TEST(TaughtObjectTracker, AReplacedModelIsSearchedForAfresh) {
  const TaughtScene taught = teachScene(21);
  ASSERT_GE(taught.models.size(), 2u);
  TaughtObjectTracker tracker;
  const auto first = taught.scene->render(0, 0);
  const cv::Mat& depth = first.frame.depth;
  const CameraIntrinsics& intrinsics = first.frame.intrinsics;
  const std::vector<std::shared_ptr<const ObjectModel>> one = {taught.models[0]};
  ASSERT_EQ(tracker.update(depth, intrinsics, one).size(), 1u);
  ASSERT_EQ(tracker.update(depth, intrinsics, one).size(), 1u);
  EXPECT_EQ(tracker.lastSearches(), 0);  // followed

  // Another object under the first one's name: its pose is not the old object's.
  ObjectModel other = *taught.models[1];
  other.name = taught.models[0]->name;
  const std::vector<std::shared_ptr<const ObjectModel>> replaced = {
      std::make_shared<const ObjectModel>(std::move(other))};
  const auto detections = tracker.update(depth, intrinsics, replaced);
  EXPECT_EQ(tracker.lastSearches(), 1);
  ASSERT_EQ(detections.size(), 1u);
  EXPECT_TRUE(
      poseIsRight(detections[0], *replaced[0], taught.taught[1], Eigen::Isometry3d::Identity()));

  // A model no longer listed is forgotten.
  EXPECT_TRUE(tracker.update(depth, intrinsics, {}).empty());
  tracker.update(depth, intrinsics, one);
  EXPECT_EQ(tracker.lastSearches(), 1);
}

}  // namespace
}  // namespace shapesense
