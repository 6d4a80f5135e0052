// Taught objects on real recordings (issue 22: "a model taught from one real frame finds the
// same object in the other frames of that recording where it is visible"). No pose truth
// exists for these frames, so the check is where the object is found: every object box the
// detector chain finds in the first frame is taught through the operator's path (its ROI,
// objectUnderRoi) and looked for in the later frames; a detection counts as the same object
// when its pose, which is the camera's motion since the first frame if the object is the same,
// aligns the rest of the (static) scene as well (the camera moves a few centimetres between
// the desk frames and pans across the room in the sweep), or, for a round object whose turn
// about its axis no view determines, when its centre lies where the camera's motion carries
// the taught one. Skipped when shared/ is not there.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "recording_fixture.h"
#include "shapesense/core/boxes/segment_box.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/tracking/taught_object_tracker.h"
#include "test_paths.h"

namespace shapesense {
namespace {

// Where the centre of a detection's box projects into the frame.
cv::Point projectedCentre(const OrientedBox& box, const CameraIntrinsics& intrinsics) {
  const Eigen::Vector2d uv = intrinsics.project(box.centre.cast<double>());
  return {static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y()))};
}

// The share of `from`'s readings (every 4th pixel each way) that `to` confirms when the
// camera's motion between them is `to_from_from`: a reading carried into `to` is confirmed
// when `to` reads within max(3 cm, 3%) of its depth there, contradicted when it reads farther
// (sees through it); nearer readings hide it and count neither way. The recordings hold
// static scenes, so the right motion confirms most of the scene and a wrong one little.
double sceneAgreement(const Frame& from, const Frame& to, const Eigen::Isometry3f& to_from_from) {
  int confirmed = 0, contradicted = 0;
  for (int v = 0; v < from.depth.rows; v += 4)
    for (int u = 0; u < from.depth.cols; u += 4) {
      const std::uint16_t reading = from.depth.at<std::uint16_t>(v, u);
      if (reading == 0) continue;
      const Eigen::Vector3d p =
          to_from_from.cast<double>() * from.intrinsics.backproject(u, v, 1e-3 * reading);
      if (p.z() <= 0.0) continue;
      const Eigen::Vector2d uv = to.intrinsics.project(p);
      const int x = static_cast<int>(std::lround(uv.x()));
      const int y = static_cast<int>(std::lround(uv.y()));
      if (x < 0 || y < 0 || x >= to.depth.cols || y >= to.depth.rows) continue;
      const double measured = 1e-3 * to.depth.at<std::uint16_t>(y, x);
      if (measured == 0.0) continue;
      const double tolerance = std::max(0.03, 0.03 * p.z());
      if (std::abs(measured - p.z()) <= tolerance) {
        ++confirmed;
      } else if (measured > p.z()) {
        ++contradicted;
      }
    }
  return confirmed + contradicted > 0 ? static_cast<double>(confirmed) / (confirmed + contradicted)
                                      : 0.0;
}

// The least share of the scene a pose must align to count as the taught object found where it
// is (a wrong place aligns little of the room; measured agreements are printed).
constexpr double kMinSceneAgreement = 0.6;
// A detection whose pose does not align the scene is still where its object is when the
// camera's motion (the pose of the frame's detection that aligns the scene best, if one does)
// carries the taught object's centre to within this of the detection's (m): a round object
// (a cup, a plate) is found with its turn about its axis undetermined, which a pose taken as
// the camera's motion shows as a turn of the whole scene.
constexpr double kMaxCentreOffsetM = 0.03;

// Judges the detections of one later frame: where its detections are, by their poses and the
// camera's motion that the best-aligning one gives.
class PlaceJudge {
 public:
  PlaceJudge(const Frame& first, const Frame& later,
             const std::vector<std::pair<const ObjectModel*, ObjectDetection>>& detections) {
    double best = kMinSceneAgreement;
    for (const auto& [model, detection] : detections) {
      const double agreement = sceneAgreement(first, later, detection.camera_from_model);
      agreements_.push_back(agreement);
      if (agreement >= best) {
        best = agreement;
        camera_motion_ = detection.camera_from_model;
      }
    }
  }
  double agreement(std::size_t k) const { return agreements_[k]; }
  // Whether detection k (of `model`) is where the taught object is.
  bool samePlace(std::size_t k, const ObjectModel& model, const ObjectDetection& detection) const {
    if (agreements_[k] >= kMinSceneAgreement) return true;
    return camera_motion_ && ((*camera_motion_) * model.box.centre - detection.box.centre).norm() <=
                                 kMaxCentreOffsetM;
  }

 private:
  std::vector<double> agreements_;
  std::optional<Eigen::Isometry3f> camera_motion_;
};

struct RecordingResult {
  int taught = 0;
  int found_same_place = 0;
  int found_elsewhere = 0;
  int searches = 0;
  // The same objects through the taught-object stage's tracker (followed from frame to frame).
  int tracked_same_place = 0;
  int tracked_elsewhere = 0;
  int tracked_followed = 0;  ///< of those, found by following (no search)
};

RecordingResult teachFirstFindLater(const std::string& recording) {
  RecordingResult out;
  const std::vector<Frame> frames = testing::replayAll(testing::realRecording(recording));
  if (frames.size() < 2) return out;
  const FrameResults first = makeDetectorChain(DetectorConfig{}).process(frames[0]);
  std::vector<std::pair<cv::Rect, ObjectModel>> models;
  for (const ObjectBox& box : first.object_boxes) {
    const cv::Rect roi = box.roi;
    const auto marked = objectUnderRoi(frames[0].depth, frames[0].intrinsics, roi.tl(),
                                       roi.br() - cv::Point(1, 1), first.segmentation->labels,
                                       first.segmentation->segments, first.planes->frame);
    const auto* object = std::get_if<RoiObject>(&marked);
    if (!object) continue;
    try {
      models.emplace_back(
          roi, teachObjectModel("object" + std::to_string(models.size()), frames[0].depth,
                                frames[0].intrinsics, object->mask));
    } catch (const std::invalid_argument&) {
      continue;  // too little shape to be taught
    }
  }
  out.taught = static_cast<int>(models.size());
  for (const auto& [roi, model] : models)
    std::printf("%s: taught the object at (%d, %d, %d x %d): %zu features, %zu points\n",
                recording.c_str(), roi.x, roi.y, roi.width, roi.height, model.features.size(),
                model.surface.size());
  for (std::size_t f = 1; f < frames.size(); ++f) {
    const SceneSurface scene(frames[f].depth, frames[f].intrinsics);
    std::vector<std::pair<const ObjectModel*, ObjectDetection>> found;
    std::vector<cv::Rect> found_rois;
    for (const auto& [roi, model] : models) {
      ++out.searches;
      if (auto detection = findObject(model, scene)) {
        found.emplace_back(&model, *detection);
        found_rois.push_back(roi);
      }
    }
    // The model's frame is the first frame's camera frame: a pose is the camera's motion.
    const PlaceJudge judge(frames[0], frames[f], found);
    for (std::size_t k = 0; k < found.size(); ++k) {
      const auto& [model, detection] = found[k];
      const cv::Rect& roi = found_rois[k];
      const cv::Point centre = projectedCentre(detection.box, frames[f].intrinsics);
      const bool same_place = judge.samePlace(k, *model, detection);
      std::printf(
          "%s: object taught at (%d, %d, %d x %d) found in frame %zu centred at (%d, %d), "
          "score %.2f, box %.0f x %.0f x %.0f cm; as the camera's motion its pose aligns "
          "%.2f of the scene: %s\n",
          recording.c_str(), roi.x, roi.y, roi.width, roi.height, f, centre.x, centre.y,
          detection.score, 100 * detection.box.size.x(), 100 * detection.box.size.y(),
          100 * detection.box.size.z(), judge.agreement(k),
          same_place ? "the taught object" : "somewhere else");
      (same_place ? out.found_same_place : out.found_elsewhere) += 1;
    }
  }
  std::printf("%s: %d taught, %d searches, %d found where taught, %d found elsewhere\n",
              recording.c_str(), out.taught, out.searches, out.found_same_place,
              out.found_elsewhere);

  // Followed: every object not followed from the previous frame is searched for at once.
  std::vector<std::shared_ptr<const ObjectModel>> shared;
  for (const auto& entry : models)
    shared.push_back(std::make_shared<const ObjectModel>(entry.second));
  TaughtObjectTrackerParams tracker_params;
  tracker_params.searches_per_frame = 0;
  TaughtObjectTracker tracker(tracker_params);
  std::map<std::string, const ObjectModel*> by_name;
  for (const auto& model : shared) by_name[model->name] = model.get();
  for (std::size_t f = 1; f < frames.size(); ++f) {
    std::vector<std::pair<const ObjectModel*, ObjectDetection>> found;
    for (const ObjectDetection& detection :
         tracker.update(frames[f].depth, frames[f].intrinsics, shared))
      found.emplace_back(by_name.at(detection.name), detection);
    const PlaceJudge judge(frames[0], frames[f], found);
    for (std::size_t k = 0; k < found.size(); ++k) {
      const auto& [model, detection] = found[k];
      const bool same_place = judge.samePlace(k, *model, detection);
      (same_place ? out.tracked_same_place : out.tracked_elsewhere) += 1;
      out.tracked_followed += detection.feature_inliers == 0 ? 1 : 0;
    }
  }
  std::printf("%s, followed: %d found where taught (%d of them by following), %d elsewhere\n",
              recording.c_str(), out.tracked_same_place, out.tracked_followed,
              out.tracked_elsewhere);
  return out;
}

// Requirement (issue 22): a taught object is found in every later frame where it is visible.
// Without truth for where each object is visible that is not asserted here; what is: no
// taught object is found away from where it is (a false detection), and, as a regression
// record, the objects found again where they are (6 of 12 searches when last measured:
// docs/benchmarks.md); the same for the objects followed from frame to frame.
TEST(RecognitionReal, TaughtObjectsAreFoundOnlyWhereTheyWereTaught) {
  if (!std::filesystem::exists(testing::realRecording("tum_fr2_desk")))
    GTEST_SKIP() << "shared/data/real is not here";
  RecordingResult all;
  for (const char* recording : {"tum_fr2_desk", "pcl_desk_sequence", "pcl_room_sweep"}) {
    const RecordingResult r = teachFirstFindLater(recording);
    all.taught += r.taught;
    all.searches += r.searches;
    all.found_same_place += r.found_same_place;
    all.found_elsewhere += r.found_elsewhere;
    all.tracked_same_place += r.tracked_same_place;
    all.tracked_elsewhere += r.tracked_elsewhere;
  }
  ASSERT_GE(all.taught, 3);
  EXPECT_EQ(all.found_elsewhere, 0);
  EXPECT_GE(all.found_same_place, 6);
  // Followed from frame to frame: nothing found away from where it is either, and at least
  // what searching every frame finds.
  EXPECT_EQ(all.tracked_elsewhere, 0);
  EXPECT_GE(all.tracked_same_place, all.found_same_place);
}

}  // namespace
}  // namespace shapesense
