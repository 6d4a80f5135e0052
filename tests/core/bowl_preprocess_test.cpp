// Depth preprocessing of the bowl detector: recursive median fill and the 8-bit mapping.
#include <gtest/gtest.h>

#include "shapesense/core/depth_preprocess.h"

namespace shapesense {
namespace {

TEST(BowlPreprocess, SingleHoleGetsLowerMedianOfItsNeighbours) {
  cv::Mat d(3, 3, CV_16UC1);
  const std::uint16_t v[9] = {10, 20, 30, 40, 0, 50, 60, 70, 80};
  for (int i = 0; i < 9; ++i) d.at<std::uint16_t>(i / 3, i % 3) = v[i];
  EXPECT_EQ(fillInvalidRecursiveMedian(d, 1), 0);
  // 8 neighbours 10..80: the lower median (4th smallest) is 40.
  EXPECT_EQ(d.at<std::uint16_t>(1, 1), 40);
}

TEST(BowlPreprocess, RecursiveFillClosesALargeHoleWithBorderValues) {
  cv::Mat d(40, 40, CV_16UC1, cv::Scalar(1000));
  d(cv::Rect(0, 20, 40, 20)).setTo(2000);  // two surfaces
  d(cv::Rect(5, 5, 30, 30)).setTo(0);      // a hole across both
  EXPECT_EQ(fillInvalidRecursiveMedian(d, 2), 0);
  double lo, hi;
  cv::minMaxLoc(d, &lo, &hi);
  EXPECT_EQ(lo, 1000);  // a median never invents values outside the neighbours'
  EXPECT_EQ(hi, 2000);
}

TEST(BowlPreprocess, NoValidPixelStaysInvalid) {
  cv::Mat d(8, 8, CV_16UC1, cv::Scalar(0));
  EXPECT_EQ(fillInvalidRecursiveMedian(d, 2), 64);
  EXPECT_EQ(cv::countNonZero(d), 0);
}

TEST(BowlPreprocess, SeedMappingHalfToThreeMetres) {
  const DepthPreprocessParams p;  // 0.5-3 m -> 2..255
  cv::Mat d(1, 6, CV_16UC1);
  const std::uint16_t v[6] = {0, 400, 500, 1750, 3000, 6000};
  for (int i = 0; i < 6; ++i) d.at<std::uint16_t>(0, i) = v[i];
  const cv::Mat m = mapDepthTo8Bit(d, p);
  EXPECT_EQ(m.at<std::uint8_t>(0, 0), 255);  // no reading = far
  EXPECT_EQ(m.at<std::uint8_t>(0, 1), 2);    // clamped near
  EXPECT_EQ(m.at<std::uint8_t>(0, 2), 2);
  EXPECT_EQ(m.at<std::uint8_t>(0, 3), 129);  // 2 + 1250 * 253 / 2500 = 128.5, rounded up
  EXPECT_EQ(m.at<std::uint8_t>(0, 4), 255);
  EXPECT_EQ(m.at<std::uint8_t>(0, 5), 255);  // clamped far
}

TEST(BowlPreprocess, ConfigurableRangeGivesFinerSteps) {
  DepthPreprocessParams p;
  p.near_m = 0.5;
  p.far_m = 1.5;  // 1 m over 253 levels: ~4 mm steps
  cv::Mat d(1, 2, CV_16UC1);
  d.at<std::uint16_t>(0, 0) = 1000;
  d.at<std::uint16_t>(0, 1) = 1008;
  const cv::Mat m = mapDepthTo8Bit(d, p);
  EXPECT_EQ(m.at<std::uint8_t>(0, 0), 129);
  EXPECT_EQ(m.at<std::uint8_t>(0, 1) - m.at<std::uint8_t>(0, 0), 2);  // 8 mm = 2 steps
  EXPECT_THROW(mapDepthTo8Bit(d, DepthPreprocessParams{.near_m = 2.0, .far_m = 1.0}), std::invalid_argument);
}

TEST(BowlPreprocess, PreprocessFillsThenMaps) {
  cv::Mat d(5, 5, CV_16UC1, cv::Scalar(1750));
  d.at<std::uint16_t>(2, 2) = 0;
  cv::Mat filled;
  const cv::Mat m = preprocessDepth(d, DepthPreprocessParams{}, &filled);
  EXPECT_EQ(filled.at<std::uint16_t>(2, 2), 1750);
  EXPECT_EQ(m.at<std::uint8_t>(2, 2), 129);
  EXPECT_EQ(d.at<std::uint16_t>(2, 2), 0);  // input untouched
}

}  // namespace
}  // namespace shapesense
