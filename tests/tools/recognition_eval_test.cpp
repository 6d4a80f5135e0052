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
  // 0.871, 0.195 false per frame: docs/benchmarks.md). The taught pixels come from the plane
  // and segment stages, and recognition is sensitive to them: a one-pixel erosion of every
  // teaching mask costs a tenth of the recall on validation cases 0-79, and a plane change that
  // cut spurious planes by a quarter added two false detections here.
  EXPECT_GE(score.recall(), 0.86);
  EXPECT_LE(score.falsePerFrameForFive(), 0.21);
  // Found poses are well inside the tolerance, so it is not what limits recall (the 90th
  // percentile of their translation errors 7.1 mm when last measured, against 1 cm; under 7 mm
  // before poses laid standing on a cluster were refined upright, 5.5 mm before the objects
  // found by their flat faces, whose poses ICP settles less closely).
  std::vector<double> translations = score.translation_errors_m;
  EXPECT_LE(quantile(translations, 0.9), 0.0075);
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

// The pose tolerance's translation, which the evaluation passes as the corner shift of a turn
// that still counts as a symmetry.
constexpr double kAlike = 0.01;

// An object whose axes are turned 30 deg about the camera's y axis, centred 1 m ahead, moved
// 10 cm to the right between the views; the estimate has it turned by `angle` about its own
// axis k before that move.
struct TurnedObject {
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  Eigen::Vector3d centre{0.0, 0.0, 1.0};
  Eigen::Matrix3d axes = Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Vector3d size{0.30, 0.20, 0.10};  // no two sides alike
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
  const auto cylinder = poseError(estimated, object.truth, object.centre, object.axes,
                                  ObjectSymmetry::kAxial, object.size, kAlike);
  EXPECT_LT(cylinder.rotation_deg, 1e-2);
  EXPECT_LT(cylinder.translation_m, 1e-6);
  const auto other = poseError(estimated, object.truth, object.centre, object.axes,
                               ObjectSymmetry::kNone, object.size, kAlike);
  EXPECT_NEAR(other.rotation_deg, 57.2958, 1e-2);
  // A cylinder tipped over is not the same pose.
  const auto tipped = poseError(object.estimate(0, 0.5), object.truth, object.centre, object.axes,
                                ObjectSymmetry::kAxial, object.size, kAlike);
  EXPECT_NEAR(tipped.rotation_deg, 28.6479, 1e-2);
}

TEST(RecognitionQuality, PoseErrorIgnoresAHalfTurnOfABoxAboutAnyOfItsAxes) {
  const TurnedObject object;
  for (int k = 0; k < 3; ++k) {
    const auto half_turn = poseError(object.estimate(k, M_PI), object.truth, object.centre,
                                     object.axes, ObjectSymmetry::kCuboid, object.size, kAlike);
    EXPECT_LT(half_turn.rotation_deg, 1e-2) << "axis " << k;
    EXPECT_LT(half_turn.translation_m, 1e-6) << "axis " << k;
    // A quarter turn changes what a box shows, and so do half turns of other shapes.
    const auto quarter = poseError(object.estimate(k, M_PI / 2), object.truth, object.centre,
                                   object.axes, ObjectSymmetry::kCuboid, object.size, kAlike);
    EXPECT_NEAR(quarter.rotation_deg, 90.0, 1e-2) << "axis " << k;
    const auto not_a_box = poseError(object.estimate(k, M_PI), object.truth, object.centre,
                                     object.axes, ObjectSymmetry::kNone, object.size, kAlike);
    EXPECT_NEAR(not_a_box.rotation_deg, 180.0, 1e-2) << "axis " << k;
  }
  // A small error on top of a half turn is measured as that small error.
  const Eigen::Isometry3f near_half =
      (object.truth * object.turn(1, M_PI) * object.turn(0, 0.05)).cast<float>();
  EXPECT_NEAR(poseError(near_half, object.truth, object.centre, object.axes,
                        ObjectSymmetry::kCuboid, object.size, kAlike)
                  .rotation_deg,
              2.8648, 1e-2);
  EXPECT_EQ(symmetryOfKind("box"), ObjectSymmetry::kCuboid);
  EXPECT_EQ(symmetryOfKind("book"), ObjectSymmetry::kCuboid);
  EXPECT_EQ(symmetryOfKind("tin"), ObjectSymmetry::kAxial);
  EXPECT_EQ(symmetryOfKind("torus"), ObjectSymmetry::kAxial);
}

TEST(RecognitionQuality, PoseErrorIgnoresAQuarterTurnOfABoxOnlyAboutAnAxisWithAlikeSides) {
  TurnedObject object;
  // Sides 23.9 and 23.6 cm across axis 2: a quarter turn about it moves a corner 2.1 mm.
  object.size = {0.239, 0.236, 0.164};
  const auto about_alike = poseError(object.estimate(2, M_PI / 2), object.truth, object.centre,
                                     object.axes, ObjectSymmetry::kCuboid, object.size, kAlike);
  EXPECT_LT(about_alike.rotation_deg, 1e-2);
  EXPECT_LT(about_alike.translation_m, 1e-6);
  // ...so a quarter turn that also leans the box 3 deg is 3 deg off.
  const Eigen::Isometry3f leaning =
      (object.truth * object.turn(2, M_PI / 2) * object.turn(0, 0.05236)).cast<float>();
  EXPECT_NEAR(poseError(leaning, object.truth, object.centre, object.axes, ObjectSymmetry::kCuboid,
                        object.size, kAlike)
                  .rotation_deg,
              3.0, 1e-2);
  // About the other two axes the quarter turn swaps sides 7 cm apart.
  for (int k = 0; k < 2; ++k) {
    const auto other = poseError(object.estimate(k, M_PI / 2), object.truth, object.centre,
                                 object.axes, ObjectSymmetry::kCuboid, object.size, kAlike);
    EXPECT_NEAR(other.rotation_deg, 90.0, 1e-2) << "axis " << k;
  }
  // Sides 1.5 cm apart: the quarter turn moves a corner 1.06 cm, more than the tolerance.
  object.size = {0.225, 0.240, 0.164};
  EXPECT_NEAR(poseError(object.estimate(2, M_PI / 2), object.truth, object.centre, object.axes,
                        ObjectSymmetry::kCuboid, object.size, kAlike)
                  .rotation_deg,
              90.0, 1e-2);
  // With no tolerance only exactly equal sides make the quarter turn a symmetry.
  object.size = {0.239, 0.236, 0.164};
  EXPECT_NEAR(poseError(object.estimate(2, M_PI / 2), object.truth, object.centre, object.axes,
                        ObjectSymmetry::kCuboid, object.size, 0.0)
                  .rotation_deg,
              90.0, 1e-2);
}

}  // namespace
}  // namespace shapesense::eval
