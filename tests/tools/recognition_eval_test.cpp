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
  // 0.523, 0.173 false per frame: docs/benchmarks.md).
  EXPECT_GE(score.recall(), 0.50);
  EXPECT_LE(score.falsePerFrameForFive(), 0.2);
  // Found poses are exact: the tolerance is not what limits recall.
  std::vector<double> translations = score.translation_errors_m;
  EXPECT_LE(quantile(translations, 0.9), 0.005);
}

TEST(RecognitionQuality, PoseErrorIgnoresTheTurnOfACylinderAboutItsAxis) {
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.translation() = Eigen::Vector3d(0.1, 0.0, 0.0);
  const Eigen::Vector3d centre(0.0, 0.0, 1.0);
  const Eigen::Vector3d axis(0.0, -1.0, 0.0);
  // The model turned 1 rad about its own axis (through its centre) before the true motion.
  const Eigen::Isometry3d turn =
      Eigen::Translation3d(centre) * Eigen::AngleAxisd(1.0, axis) * Eigen::Translation3d(-centre);
  const Eigen::Isometry3f estimated = (truth * turn).cast<float>();
  const auto cylinder = poseError(estimated, truth, centre, axis, true);
  EXPECT_LT(cylinder.rotation_deg, 1e-2);
  EXPECT_LT(cylinder.translation_m, 1e-6);
  const auto box = poseError(estimated, truth, centre, axis, false);
  EXPECT_NEAR(box.rotation_deg, 57.2958, 1e-2);
}

}  // namespace
}  // namespace shapesense::eval
