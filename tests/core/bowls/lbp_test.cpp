// LBP codes over 3x3 cell grids: hand-made patterns, and integral-image codes equal to the
// direct summation for every feature of a window.
#include <string>

#include <gtest/gtest.h>

#include "shapesense/core/bowls/lbp.h"
#include "simd_targets.h"

namespace shapesense {
namespace {

cv::Mat grid(const int v[9], int cw, int ch) {
  cv::Mat m(3 * ch, 3 * cw, CV_8UC1);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(cv::Rect(j * cw, i * ch, cw, ch)).setTo(v[i * 3 + j]);
  return m;
}

TEST(Lbp, HandMadePatterns) {
  // Bit k = neighbour k >= centre, k clockwise from the top-left: 0 1 2 / 7 . 3 / 6 5 4.
  const int only_top_left[9] = {9, 1, 1, 1, 5, 1, 1, 1, 1};
  EXPECT_EQ(lbpCodeDirect(grid(only_top_left, 1, 1), 0, 0, 1, 1), 0x01);
  const int flat[9] = {7, 7, 7, 7, 7, 7, 7, 7, 7};
  EXPECT_EQ(lbpCodeDirect(grid(flat, 2, 2), 0, 0, 2, 2), 0xFF);  // ties count as >=
  const int right_column[9] = {0, 0, 9, 0, 5, 9, 0, 0, 9};       // bits 2, 3, 4
  EXPECT_EQ(lbpCodeDirect(grid(right_column, 2, 1), 0, 0, 2, 1), 0x1C);
  const int left_column[9] = {9, 0, 0, 9, 5, 0, 9, 0, 0};  // bits 0, 6, 7
  EXPECT_EQ(lbpCodeDirect(grid(left_column, 1, 2), 0, 0, 1, 2), 0xC1);
  // A depth ramp increasing downwards (a table seen from above): the bottom row is farther.
  const int ramp[9] = {10, 10, 10, 20, 20, 20, 30, 30, 30};
  EXPECT_EQ(lbpCodeDirect(grid(ramp, 2, 2), 0, 0, 2, 2), 0xF8);  // bits 3 (tie), 4, 5, 6, 7 (tie)
}

TEST(Lbp, IntegralCodesEqualDirectCodesForEveryFeature) {
  cv::RNG rng(42);
  cv::Mat img(40, 50, CV_8UC1);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  const cv::Mat ii = lbpIntegral(img);
  const auto features = enumerateLbpFeatures(24, 18, 2);
  for (const auto& f : features)
    for (const auto& [wx, wy] : {std::pair{0, 0}, std::pair{5, 3}, std::pair{26, 22}}) {
      ASSERT_EQ(lbpCodeAt(ii, f, wx, wy), lbpCodeDirect(img, wx + f.x, wy + f.y, f.cw, f.ch))
          << f.x << "," << f.y << " cell " << f.cw << "x" << f.ch << " at " << wx << "," << wy;
    }
}

TEST(Lbp, CodeImagesEqualDirectCodesAtEveryPositionAndZeroWhereTheGridDoesNotFit) {
  testing::forEachSimdTarget([&](const std::string& target) {
    SCOPED_TRACE(target);
    cv::RNG rng(11);
    // Odd sizes (the borders of 2-pixel cells do not divide evenly), tiny ones (no grid fits,
    // exactly one fits), and views into a larger image whose rows are not contiguous.
    const cv::Size sizes[] = {{37, 45}, {45, 37}, {2, 2},  {3, 3},   {6, 6},
                              {5, 7},   {64, 1},  {1, 64}, {533, 17}};
    for (const cv::Size size : sizes) {
      cv::Mat big(size.height + 3, size.width + 5, CV_8UC1);
      rng.fill(big, cv::RNG::UNIFORM, 0, 256);
      const cv::Mat img = big(cv::Rect(2, 1, size.width, size.height));
      if (size.width > 20 && size.height > 20) {
        img(cv::Rect(10, 10, 8, 6)).setTo(100);  // ties (>=) inside a flat patch
        img(cv::Rect(2, 20, 6, 8)).setTo(255);   // ties at the top of the range
      }
      for (int ch = 1; ch <= 2; ++ch)
        for (int cw = 1; cw <= 2; ++cw) {
          const cv::Mat codes = lbpCodeImage(img, cw, ch);
          ASSERT_EQ(codes.type(), CV_8UC1);
          ASSERT_EQ(codes.size(), img.size());
          for (int y = 0; y < img.rows; ++y)
            for (int x = 0; x < img.cols; ++x) {
              const bool fits = x + 3 * cw <= img.cols && y + 3 * ch <= img.rows;
              const int want = fits ? lbpCodeDirect(img, x, y, cw, ch) : 0;
              ASSERT_EQ(codes.at<std::uint8_t>(y, x), want)
                  << "cell " << cw << "x" << ch << " at " << x << "," << y << " image " << size;
            }
        }
    }
    EXPECT_THROW(lbpCodeImage(cv::Mat(8, 8, CV_8UC1), 1, 3), std::invalid_argument);
  });
}

// Only some rows computed (the detector skips rows no gated window covers): those rows equal the
// full code image, whatever rows were skipped before them (the cell-sum ring restarts), and the
// others are 0.
TEST(Lbp, CodeImageOfSelectedRowsEqualsTheFullImageThereAndZeroElsewhere) {
  testing::forEachSimdTarget([&](const std::string& target) {
    SCOPED_TRACE(target);
    cv::RNG rng(5);
    cv::Mat img(61, 53, CV_8UC1);
    rng.fill(img, cv::RNG::UNIFORM, 0, 256);
    for (int pattern = 0; pattern < 6; ++pattern) {
      std::vector<std::uint8_t> rows(static_cast<std::size_t>(img.rows));
      for (std::size_t y = 0; y < rows.size(); ++y)
        rows[y] = pattern == 0   ? 1
                  : pattern == 1 ? 0
                  : pattern == 2 ? (y / 3) % 2  // short runs and gaps
                  : pattern == 3 ? (y >= 20 && y < 27) || y == 40
                  : pattern == 4 ? y + 2 >= rows.size()  // only rows where no grid fits
                                 : static_cast<std::uint8_t>(rng.uniform(0, 2));
      for (int ch = 1; ch <= 2; ++ch)
        for (int cw = 1; cw <= 2; ++cw) {
          const cv::Mat full = lbpCodeImage(img, cw, ch);
          const cv::Mat some = lbpCodeImage(img, cw, ch, rows);
          ASSERT_EQ(some.size(), img.size());
          for (int y = 0; y < img.rows; ++y) {
            const cv::Mat want = rows[static_cast<std::size_t>(y)]
                                     ? full.row(y)
                                     : cv::Mat::zeros(1, img.cols, CV_8UC1);
            ASSERT_EQ(cv::countNonZero(some.row(y) != want), 0)
                << "pattern " << pattern << " cell " << cw << "x" << ch << " row " << y;
          }
        }
    }
    EXPECT_THROW(lbpCodeImage(img, 2, 2, std::vector<std::uint8_t>(3, 1)), std::invalid_argument);
  });
}

TEST(Lbp, EnumerationCoversAllFittingGrids) {
  // 24x24, cells 1-2: 22*22 (1x1) + 19*22 (2x1) + 22*19 (1x2) + 19*19 (2x2).
  EXPECT_EQ(enumerateLbpFeatures(24, 24, 2).size(), 22u * 22 + 19 * 22 * 2 + 19 * 19);
  for (const auto& f : enumerateLbpFeatures(24, 16, 2)) {
    EXPECT_LE(f.x + 3 * f.cw, 24);
    EXPECT_LE(f.y + 3 * f.ch, 16);
  }
}

}  // namespace
}  // namespace shapesense
