// SegComp scoring on hand-made label images with exactly known answers.
#include "shapesense/core/segmentation/segmentation_scoring.h"

#include <gtest/gtest.h>

namespace shapesense {
namespace {

cv::Mat labels(int rows, int cols) { return cv::Mat(rows, cols, CV_16UC1, cv::Scalar(0)); }

// Truth: left half 1, right half 2 (10x20 image, 100 px each).
cv::Mat twoHalves() {
  cv::Mat t = labels(10, 20);
  t(cv::Rect(0, 0, 10, 10)).setTo(1);
  t(cv::Rect(10, 0, 10, 10)).setTo(2);
  return t;
}

TEST(SegmentationScoring, PerfectSegmentationWithOtherIds) {
  const cv::Mat t = twoHalves();
  cv::Mat f = labels(10, 20);
  f(cv::Rect(0, 0, 10, 10)).setTo(7);
  f(cv::Rect(10, 0, 10, 10)).setTo(3);
  const SegCompScore s = scoreSegmentation(f, t);
  EXPECT_EQ(s.truth_regions, 2);
  EXPECT_EQ(s.found_regions, 2);
  EXPECT_EQ(s.correct, 2);
  EXPECT_DOUBLE_EQ(s.correct_fraction, 1.0);
  EXPECT_DOUBLE_EQ(s.pixel_accuracy, 1.0);
  EXPECT_EQ(s.missed, 0);
  EXPECT_EQ(s.noise, 0);
}

TEST(SegmentationScoring, ShiftedBoundaryBelowAndAboveThreshold) {
  const cv::Mat t = twoHalves();
  // Found boundary at column 12: region A = 120 px (100 of truth 1, 20 of truth 2), B = 80 px.
  cv::Mat f = labels(10, 20);
  f(cv::Rect(0, 0, 12, 10)).setTo(1);
  f(cv::Rect(12, 0, 8, 10)).setTo(2);
  SegCompScore s = scoreSegmentation(f, t, 0.8);
  // A: O=100 >= 0.8*100 and >= 0.8*120=96 -> correct; B: O=80 >= 0.8*100 and >= 0.8*80 -> correct.
  EXPECT_EQ(s.correct, 2);
  EXPECT_DOUBLE_EQ(s.pixel_accuracy, 180.0 / 200.0);
  // At T = 0.9: A needs 108 of its 120 px in truth 1 (has 100) -> not correct; B needs 90 (has 80).
  s = scoreSegmentation(f, t, 0.9);
  EXPECT_EQ(s.correct, 0);
  EXPECT_EQ(s.missed, 2);
  EXPECT_EQ(s.noise, 2);
}

TEST(SegmentationScoring, OverAndUnderSegmentation) {
  const cv::Mat t = twoHalves();
  // Truth 1 split into two found regions (top / bottom); truth 2 detected.
  cv::Mat f = labels(10, 20);
  f(cv::Rect(0, 0, 10, 5)).setTo(1);
  f(cv::Rect(0, 5, 10, 5)).setTo(2);
  f(cv::Rect(10, 0, 10, 10)).setTo(3);
  SegCompScore s = scoreSegmentation(f, t);
  EXPECT_EQ(s.correct, 1);
  EXPECT_EQ(s.over_segmented, 1);
  EXPECT_EQ(s.under_segmented, 0);
  EXPECT_DOUBLE_EQ(s.correct_fraction, 0.5);
  EXPECT_DOUBLE_EQ(s.pixel_accuracy, 1.0);
  // One found region covering everything: both truth regions under-segmented.
  f.setTo(5);
  s = scoreSegmentation(f, t);
  EXPECT_EQ(s.correct, 0);
  EXPECT_EQ(s.under_segmented, 2);
  EXPECT_DOUBLE_EQ(s.pixel_accuracy, 0.5);
}

TEST(SegmentationScoring, UnlabelledTruthIgnoredUnassignedFoundCounts) {
  cv::Mat t = twoHalves();
  t(cv::Rect(0, 0, 20, 2)).setTo(0);  // top two rows have no truth: 80 + 80 px remain
  cv::Mat f = labels(10, 20);
  f(cv::Rect(0, 0, 10, 10)).setTo(1);  // extends into the unlabelled rows: not penalised
  // Right half: 20 px of truth 2 left unassigned (found 0).
  f(cv::Rect(10, 4, 10, 6)).setTo(2);
  const SegCompScore s = scoreSegmentation(f, t);
  EXPECT_EQ(s.truth_regions, 2);
  // Truth 2 (80 px) has 60 px in found 2: 60 < 0.8 * 80, so only truth 1 is correct.
  EXPECT_EQ(s.correct, 1);
  EXPECT_DOUBLE_EQ(s.pixel_accuracy, (80.0 + 60.0) / 160.0);
}

TEST(SegmentationScoring, SmallTruthRegionsExcludedFromCounts) {
  cv::Mat t = labels(100, 100);
  t.setTo(1);
  t(cv::Rect(0, 0, 5, 5)).setTo(2);  // 25 px < 0.5% of 10000
  cv::Mat f = labels(100, 100);
  f.setTo(1);
  const SegCompScore s = scoreSegmentation(f, t);
  EXPECT_EQ(s.truth_regions, 1);
  EXPECT_EQ(s.correct, 1);
  EXPECT_DOUBLE_EQ(s.pixel_accuracy, 9975.0 / 10000.0);
}

}  // namespace
}  // namespace shapesense
