// The default segmentation (planes_objects) on the evaluation's test split and on the labelled
// real OSD frames, against the targets of the detection-quality issue (#18): each planar face
// its own region, each curved object one region, real objects kept apart from the table and
// from each other. A bound under a target is a regression record and says so.

#include <gtest/gtest.h>

#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/eval/scene_splits.h"
#include "shapesense/eval/segment_eval.h"
#include "test_paths.h"

namespace shapesense {
namespace {

constexpr int kTestFrames = 60;

struct SplitScore {
  int truth_regions = 0, correct = 0;
  int curved_objects = 0, curved_objects_split = 0;
  double pixel_accuracy_sum = 0;
  int frames = 0;
};

SplitScore scoreTestSplit(const DetectorConfig& config) {
  SplitScore s;
  HoughPlaneDetector hough(config.hough_params);
  for (int i = 0; i < kTestFrames; ++i) {
    const eval::EvalScene scene = eval::evalScene(eval::Split::kTest, i);
    const auto f = synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
    const PlaneDetection planes = hough.detect(f.frame.depth, f.frame.intrinsics);
    const SegmentationResult seg =
        segmentFrame(f.frame, kDefaultSegmentationMethod, config.segmentation_params, &planes);
    const SegCompScore sc = eval::scoreSegments(seg.labels, f.truth);
    s.truth_regions += sc.truth_regions;
    s.correct += sc.correct;
    s.pixel_accuracy_sum += sc.pixel_accuracy;
    for (const SegCompTruthRegion& region : sc.truth) {
      if (!region.considered || !eval::isCurvedObjectRegion(region.label, f.truth)) continue;
      ++s.curved_objects;
      s.curved_objects_split += region.outcome == SegCompOutcome::kOverSegmented;
    }
    ++s.frames;
  }
  return s;
}

const SplitScore& testSplitScore() {
  static const SplitScore score = scoreTestSplit(DetectorConfig{});
  return score;
}

TEST(SegmentationQuality, DefaultIsPlanesAndObjects) {
  EXPECT_EQ(kDefaultSegmentationMethod, SegmentationMethod::kPlanesAndObjects);
  EXPECT_EQ(DetectorConfig{}.segmentation, SegmentationMethod::kPlanesAndObjects);
}

// Requirement: each curved object one region. Regression record: at most 20% of them split
// (reached 14 of 79). Curved objects that plane_prediction cuts at a rim or a bend, or whose
// flat top is a region of its own, are joined again; without that 34 of the 79 are split.
TEST(SegmentationQuality, CurvedObjectsSplitRegressionRecord) {
  const SplitScore& s = testSplitScore();
  ASSERT_GT(s.curved_objects, 60);
  EXPECT_LE(s.curved_objects_split, 0.20 * s.curved_objects)
      << s.curved_objects_split << " of " << s.curved_objects;
  DetectorConfig without;
  without.segmentation_params.planes_and_objects.join_curved_objects = false;
  const SplitScore before = scoreTestSplit(without);
  EXPECT_GT(before.curved_objects_split, s.curved_objects_split);
  std::printf("curved objects split: %d of %d, without joining %d\n", s.curved_objects_split,
              s.curved_objects, before.curved_objects_split);
}

// Target: pixel accuracy >= 0.95 (reached 0.976).
TEST(SegmentationQuality, DefaultMeetsThePixelAccuracyTarget) {
  const SplitScore& s = testSplitScore();
  ASSERT_EQ(s.frames, kTestFrames);
  EXPECT_GE(s.pixel_accuracy_sum / s.frames, 0.95);
}

// Target: correct >= 0.85 on the test split (reached 0.879 on these 60 frames and 0.864 on the
// 100 test frames of shapesense-eval; 0.853 on the validation split; plane_prediction 0.53 on
// the same split, depth_step 0.10). Regression record: 0.87.
TEST(SegmentationQuality, DefaultMeetsTheCorrectTarget) {
  const SplitScore& s = testSplitScore();
  ASSERT_GT(s.truth_regions, 500);
  const double correct = static_cast<double>(s.correct) / s.truth_regions;
  EXPECT_GE(correct, 0.85);
  EXPECT_GE(correct, 0.87) << "regression record";
}

eval::RealSegmentScore realScore(const char* recording) {
  const DetectorConfig config;
  HoughPlaneDetector hough(config.hough_params);
  eval::RealSegmentScore total;
  for (const auto& f : eval::loadLabelledRecording(testing::realRecording(recording))) {
    const PlaneDetection planes = hough.detect(f.frame.depth, f.frame.intrinsics);
    const SegmentationResult seg =
        segmentFrame(f.frame, kDefaultSegmentationMethod, config.segmentation_params, &planes);
    total.add(eval::scoreRealSegments(seg.labels, f.labels, f.frame.depth));
  }
  return total;
}

// Target: >= 0.95 of the real objects kept apart, the table one region (reached 96 of 98 and
// 33 of 33 on mosd_test; 40 of 42 and 6 of 6 on mosd_tabletop).
TEST(SegmentationQuality, RealObjectsAreKeptApart) {
  for (const char* recording : {"mosd_test", "mosd_tabletop"}) {
    if (!std::filesystem::exists(testing::realRecording(recording) / "depth.txt"))
      GTEST_SKIP() << "no " << recording;
    const eval::RealSegmentScore s = realScore(recording);
    ASSERT_GT(s.objects, 20) << recording;
    EXPECT_GE(s.keptApartFraction(), 0.95) << recording;
    EXPECT_EQ(s.table_whole, s.frames) << recording;
  }
}

}  // namespace
}  // namespace shapesense
