// Depth preprocessing of the bowl detector: recursive median fill and the 8-bit mapping.
#include <string>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>

#include <opencv2/imgproc.hpp>

#include "shapesense/core/bowls/depth_preprocess.h"
#include "simd_targets.h"

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
  const cv::Mat m = DepthTo8BitMap(p)(d);
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
  const cv::Mat m = DepthTo8BitMap(p)(d);
  EXPECT_EQ(m.at<std::uint8_t>(0, 0), 129);
  EXPECT_EQ(m.at<std::uint8_t>(0, 1) - m.at<std::uint8_t>(0, 0), 2);  // 8 mm = 2 steps
  EXPECT_THROW(DepthTo8BitMap(DepthPreprocessParams{.near_m = 2.0, .far_m = 1.0}),
               std::invalid_argument);
}

TEST(BowlPreprocess, PreprocessFillsThenMaps) {
  cv::Mat d(5, 5, CV_16UC1, cv::Scalar(1750));
  d.at<std::uint16_t>(2, 2) = 0;
  cv::Mat filled;
  const cv::Mat m = preprocessDepth(d, DepthTo8BitMap(DepthPreprocessParams{}), &filled);
  EXPECT_EQ(filled.at<std::uint16_t>(2, 2), 1750);
  EXPECT_EQ(m.at<std::uint8_t>(2, 2), 129);
  EXPECT_EQ(d.at<std::uint16_t>(2, 2), 0);  // input untouched
}

// The fill as first written (every pixel visited, std::nth_element on the valid neighbours):
// the optimised fill must give exactly its result.
int referenceFill(cv::Mat& d, int passes) {
  int remaining = cv::countNonZero(d == 0);
  for (int pass = 0; pass < passes && remaining > 0; ++pass) {
    const bool forward = pass % 2 == 0;
    for (int i = 0; i < d.rows; ++i)
      for (int j = 0; j < d.cols; ++j) {
        const int r = forward ? i : d.rows - 1 - i, c = forward ? j : d.cols - 1 - j;
        if (d.at<std::uint16_t>(r, c) != 0) continue;
        std::array<std::uint16_t, 8> nb{};
        int n = 0;
        for (int rr = r - 1; rr <= r + 1; ++rr)
          for (int cc = c - 1; cc <= c + 1; ++cc)
            if ((rr != r || cc != c) && rr >= 0 && rr < d.rows && cc >= 0 && cc < d.cols &&
                d.at<std::uint16_t>(rr, cc) != 0)
              nb[static_cast<std::size_t>(n++)] = d.at<std::uint16_t>(rr, cc);
        if (n == 0) continue;
        std::nth_element(nb.begin(), nb.begin() + (n - 1) / 2, nb.begin() + n);
        d.at<std::uint16_t>(r, c) = nb[static_cast<std::size_t>((n - 1) / 2)];
        --remaining;
      }
  }
  return remaining;
}

TEST(BowlPreprocess, FillEqualsTheReferenceOnRandomHoles) {
  testing::forEachSimdTarget([&](const std::string& target) {
    SCOPED_TRACE(target);
    std::mt19937 rng(7);
    for (int trial = 0; trial < 40; ++trial) {
      // Odd sizes (row tails shorter than a SIMD block), a view into a larger image (rows not
      // contiguous), values up to 65535, holes from single pixels to most of the image.
      const int rows = 1 + static_cast<int>(rng() % 40), cols = 1 + static_cast<int>(rng() % 45);
      cv::Mat big(rows + 2, cols + 5, CV_16UC1);
      cv::Mat d = big(cv::Rect(3, 1, cols, rows));
      const double hole_fraction = (trial % 5) * 0.22;
      std::uniform_real_distribution<double> u(0.0, 1.0);
      for (int r = 0; r < big.rows; ++r)
        for (int c = 0; c < big.cols; ++c) {
          const bool extreme = rng() % 10 == 0;
          big.at<std::uint16_t>(r, c) =
              static_cast<std::uint16_t>(extreme ? 65535 - rng() % 2 : 400 + rng() % 40);
        }
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (u(rng) < hole_fraction) d.at<std::uint16_t>(r, c) = 0;
      if (trial % 2 == 1) {  // a large empty region too, like a room that reads no depth
        const int x0 = static_cast<int>(rng() % static_cast<unsigned>(cols)),
                  y0 = static_cast<int>(rng() % static_cast<unsigned>(rows));
        d(cv::Rect(x0, y0, cols - x0, rows - y0)).setTo(0);
      }
      for (const int passes : {1, 2, 3}) {
        cv::Mat want = d.clone(), got_big = big.clone();
        cv::Mat got = got_big(cv::Rect(3, 1, cols, rows));
        const int want_left = referenceFill(want, passes);
        EXPECT_EQ(fillInvalidRecursiveMedian(got, passes), want_left) << trial << " " << passes;
        EXPECT_EQ(cv::countNonZero(got != want), 0) << trial << " " << passes;
        // Outside the view untouched.
        got(cv::Rect(0, 0, cols, rows)).setTo(0);
        cv::Mat orig_outside = big.clone();
        orig_outside(cv::Rect(3, 1, cols, rows)).setTo(0);
        EXPECT_EQ(cv::countNonZero(got_big != orig_outside), 0) << trial << " " << passes;
      }
    }
  });
}

// Larger frames than above (many 8-pixel blocks per row, interior and border blocks) with
// Kinect-like content: smooth surfaces with noise, scattered dropouts, large shadow and
// out-of-range regions, rows and columns that read nothing, and extreme values.
TEST(BowlPreprocess, FillEqualsTheReferenceOnLargeFramesWithLargeHoles) {
  testing::forEachSimdTarget([&](const std::string& target) {
    SCOPED_TRACE(target);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int trial = 0; trial < 24; ++trial) {
      const int rows = 20 + static_cast<int>(rng() % 100),
                cols = 20 + static_cast<int>(rng() % 150);
      cv::Mat d(rows, cols, CV_16UC1);
      const double gx = u(rng) * 20 - 10, gy = u(rng) * 20 - 10;
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) {
          double v = 1500 + gx * c + gy * r + static_cast<double>(rng() % 7);
          if (trial % 4 == 3 && rng() % 8 == 0) v = 65535 - rng() % 3;  // extreme readings
          if (trial % 4 == 2 && rng() % 8 == 0) v = 1 + rng() % 3;
          d.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(std::clamp(v, 1.0, 65535.0));
        }
      // A few step edges between surfaces.
      d(cv::Rect(0, rows / 3, cols, rows / 3)) += 400;
      // Scattered dropouts, then large holes of random shape (rectangles and discs).
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (u(rng) < 0.05 * (trial % 3)) d.at<std::uint16_t>(r, c) = 0;
      for (int k = 0; k < 1 + trial % 4; ++k) {
        const int x = static_cast<int>(rng() % static_cast<unsigned>(cols)),
                  y = static_cast<int>(rng() % static_cast<unsigned>(rows));
        const int w = 1 + static_cast<int>(rng() % static_cast<unsigned>(cols)),
                  h = 1 + static_cast<int>(rng() % static_cast<unsigned>(rows));
        if (k % 2 == 0)
          d(cv::Rect(x, y, std::min(w, cols - x), std::min(h, rows - y))).setTo(0);
        else
          cv::circle(d, {x, y}, std::max(w, h) / 3, cv::Scalar(0), -1);
      }
      if (trial % 5 == 0) d.rowRange(0, rows / 2).setTo(0);  // a room that reads nothing
      if (trial % 6 == 1) d.col(cols - 1).setTo(0), d.col(0).setTo(0);
      for (const int passes : {1, 2, 3}) {
        cv::Mat want = d.clone(), got = d.clone();
        const int want_left = referenceFill(want, passes);
        EXPECT_EQ(fillInvalidRecursiveMedian(got, passes), want_left) << trial << " " << passes;
        EXPECT_EQ(cv::countNonZero(got != want), 0) << trial << " " << passes;
      }
    }
  });
}

// The table a DepthTo8BitMap builds once (and the detector keeps) maps every depth value as the
// linear, clamped formula does; mapping several images with one map equals mapping each afresh.
TEST(BowlPreprocess, PrebuiltMapEqualsTheFormulaAndFreshMapping) {
  for (const DepthPreprocessParams p :
       {DepthPreprocessParams{},
        DepthPreprocessParams{
            .near_m = 0.4, .far_m = 1.9, .low = 0, .high = 200, .unfilled_value = 7}}) {
    const DepthTo8BitMap map(p);
    ASSERT_EQ(map.table().size(), 65536u);
    EXPECT_EQ(map.table()[0], p.unfilled_value);
    const double near_mm = p.near_m * 1000, far_mm = p.far_m * 1000;
    for (int v = 1; v < 65536; ++v) {
      const double z = std::clamp(static_cast<double>(v), near_mm, far_mm);
      const long want = std::lround(p.low + (z - near_mm) * (p.high - p.low) / (far_mm - near_mm));
      ASSERT_EQ(map.table()[static_cast<std::size_t>(v)], want) << v;
    }
    std::mt19937 rng(3);
    for (int k = 0; k < 3; ++k) {
      cv::Mat d(37, 53, CV_16UC1);
      for (int r = 0; r < d.rows; ++r)
        for (int c = 0; c < d.cols; ++c)
          d.at<std::uint16_t>(r, c) =
              static_cast<std::uint16_t>(rng() % 3 == 0 ? 0 : rng() % 65536);
      EXPECT_EQ(cv::countNonZero(map(d) != DepthTo8BitMap(p)(d)), 0);
      cv::Mat f1, f2;
      EXPECT_EQ(cv::countNonZero(preprocessDepth(d, map, &f1) !=
                                 preprocessDepth(d, DepthTo8BitMap(p), &f2)),
                0);
      EXPECT_EQ(cv::countNonZero(f1 != f2), 0);
    }
  }
}

// Where the map runs in vectors (a fixed-point form of its ramp, kept only when it reproduces
// the table), every 16-bit depth still maps to the table's value: the shipped models' range and
// ranges whose bounds fall between millimetres.
TEST(BowlPreprocess, MappingAnImageGivesTheTableForEveryDepth) {
  cv::Mat every_depth(256, 256, CV_16UC1);
  for (int v = 0; v < 65536; ++v)
    every_depth.at<std::uint16_t>(v / 256, v % 256) = static_cast<std::uint16_t>(v);
  for (const DepthPreprocessParams p :
       {DepthPreprocessParams{},
        DepthPreprocessParams{.near_m = 0.5, .far_m = 3.0, .low = 2, .high = 255},
        DepthPreprocessParams{.near_m = 0.4003, .far_m = 4.5007, .low = 0, .high = 255},
        DepthPreprocessParams{.near_m = 0.5, .far_m = 0.6, .low = 10, .high = 250},
        DepthPreprocessParams{.near_m = 0.0, .far_m = 60.0, .low = 0, .high = 255}}) {
    const DepthTo8BitMap map(p);
    const cv::Mat mapped = map(every_depth);
    for (int v = 0; v < 65536; ++v)
      ASSERT_EQ(mapped.at<std::uint8_t>(v / 256, v % 256), map.table()[static_cast<std::size_t>(v)])
          << "depth " << v << " mm, range " << p.near_m << "-" << p.far_m;
  }
}

}  // namespace
}  // namespace shapesense
