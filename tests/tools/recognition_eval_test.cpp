// Taught-object recognition (issue 22) on the test split's recognition cases, through the
// operator's path: each object taught from its image box in one view (after the detector chain),
// looked for in three views from 10-35 deg around the table.

#include "shapesense/eval/recognition_eval.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "shapesense/core/geometry/order_statistics.h"

namespace shapesense::eval {
namespace {

TEST(RecognitionQuality, TestSplitRecallAndFalseDetections) {
  const RecognitionScore score = scoreRecognition(Split::kTest, 0, 20);
  std::printf("%s\n", formatRecognitionScore("[recognition, test split, 20 cases]", score).c_str());
  ASSERT_GE(score.required, 150);
  // Requirement (issue 22): recall >= 0.90 at <= 1 cm and 5 deg with >= 50% of the object
  // visible, and <= 0.1 false detections per frame for five taught objects: NOT met. The bounds
  // below are a regression record, just under what the code reached on these 20 cases (recall
  // 0.866, 0.281 false per frame: docs/benchmarks.md). The taught pixels come from the plane
  // and segment stages, and recognition is sensitive to them: a one-pixel erosion of every
  // teaching mask costs a tenth of the recall on validation cases 0-79, and a plane change that
  // cut spurious planes by a quarter added two false detections here.
  EXPECT_GE(score.recall(), 0.85);
  EXPECT_LE(score.falsePerFrameForFive(), 0.30);
  // Found poses are well inside the tolerance, so it is not what limits recall (the 90th
  // percentile of their translation errors 6.1 mm when last measured, against 1 cm; 5.5 mm
  // before the objects found by their flat faces, whose poses ICP settles less closely).
  std::vector<double> translations = score.translation_errors_m;
  EXPECT_LE(quantile(translations, 0.9), 0.007);
  // Every required object not found is listed, with what the check says of its truth pose; a
  // wrong pose is listed once, as a miss and among the wrong poses, with what the check says
  // of it too: it passes, as findObject verified it.
  ASSERT_EQ(static_cast<int>(score.misses.size()), score.required - score.found);
  int listed_wrong = 0;
  for (const RecognitionMiss& miss : score.misses) {
    listed_wrong += miss.detected.has_value();
    ASSERT_TRUE(miss.truth_check.has_value());
    EXPECT_FALSE(miss.truth_check->figures.empty());
    ASSERT_EQ(miss.reported_check.has_value(), miss.detected.has_value());
    if (miss.reported_check) {
      EXPECT_EQ(miss.reported_check->failed, "");
    }
  }
  EXPECT_EQ(listed_wrong, score.wrong_pose);
}

// An object whose axes are turned 30 deg about the camera's y axis, centred 1 m ahead, moved
// 10 cm to the right between the views; the estimate has it turned by `angle` about its own
// axis k before that move.
struct TurnedObject {
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  Eigen::Vector3d centre{0.0, 0.0, 1.0};
  Eigen::Matrix3d axes = Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Isometry3d turn(int k, double angle) const {
    return Eigen::Translation3d(centre) * Eigen::AngleAxisd(angle, axes.col(k)) *
           Eigen::Translation3d(-centre);
  }
  Eigen::Isometry3f estimate(int k, double angle) const {
    return (truth * turn(k, angle)).cast<float>();
  }
  TurnedObject() { truth.translation() = Eigen::Vector3d(0.1, 0.0, 0.0); }
};

TEST(RecognitionQuality, PoseErrorIgnoresTheTurnOfACylinderAboutItsAxis) {
  const TurnedObject object;
  const Eigen::Isometry3f estimated = object.estimate(2, 1.0);
  const auto cylinder =
      poseError(estimated, object.truth, object.centre, object.axes, ObjectSymmetry::kAxial);
  EXPECT_LT(cylinder.rotation_deg, 1e-2);
  EXPECT_LT(cylinder.translation_m, 1e-6);
  const auto other =
      poseError(estimated, object.truth, object.centre, object.axes, ObjectSymmetry::kNone);
  EXPECT_NEAR(other.rotation_deg, 57.2958, 1e-2);
  // A cylinder tipped over is not the same pose.
  const auto tipped = poseError(object.estimate(0, 0.5), object.truth, object.centre, object.axes,
                                ObjectSymmetry::kAxial);
  EXPECT_NEAR(tipped.rotation_deg, 28.6479, 1e-2);
}

TEST(RecognitionQuality, PoseErrorIgnoresAHalfTurnOfABoxAboutAnyOfItsAxes) {
  const TurnedObject object;
  for (int k = 0; k < 3; ++k) {
    const auto half_turn = poseError(object.estimate(k, M_PI), object.truth, object.centre,
                                     object.axes, ObjectSymmetry::kCuboid);
    EXPECT_LT(half_turn.rotation_deg, 1e-2) << "axis " << k;
    EXPECT_LT(half_turn.translation_m, 1e-6) << "axis " << k;
    // A quarter turn changes what a box shows, and so do half turns of other shapes.
    const auto quarter = poseError(object.estimate(k, M_PI / 2), object.truth, object.centre,
                                   object.axes, ObjectSymmetry::kCuboid);
    EXPECT_NEAR(quarter.rotation_deg, 90.0, 1e-2) << "axis " << k;
    const auto not_a_box = poseError(object.estimate(k, M_PI), object.truth, object.centre,
                                     object.axes, ObjectSymmetry::kNone);
    EXPECT_NEAR(not_a_box.rotation_deg, 180.0, 1e-2) << "axis " << k;
  }
  // A small error on top of a half turn is measured as that small error.
  const Eigen::Isometry3f near_half =
      (object.truth * object.turn(1, M_PI) * object.turn(0, 0.05)).cast<float>();
  EXPECT_NEAR(
      poseError(near_half, object.truth, object.centre, object.axes, ObjectSymmetry::kCuboid)
          .rotation_deg,
      2.8648, 1e-2);
  EXPECT_EQ(symmetryOfKind("box"), ObjectSymmetry::kCuboid);
  EXPECT_EQ(symmetryOfKind("tin"), ObjectSymmetry::kAxial);
  EXPECT_EQ(symmetryOfKind("torus"), ObjectSymmetry::kAxial);
}

}  // namespace
}  // namespace shapesense::eval
