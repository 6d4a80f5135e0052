// Non-maximum suppression of bowl detections by the seed's rule: two detections are distinct
// objects when the circles inscribed in their boxes overlap by less than 10%.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_eval.h"

namespace shapesense {
namespace {

// Overlap by counting pixels on a fine grid (reference for the lens formula).
double numericOverlap(const cv::Rect& a, const cv::Rect& b) {
  const double r1 = std::min(a.width, a.height) / 2.0, r2 = std::min(b.width, b.height) / 2.0;
  const double ax = a.x + a.width / 2.0, ay = a.y + a.height / 2.0, bx = b.x + b.width / 2.0,
               by = b.y + b.height / 2.0;
  const double step = 0.1;
  long both = 0;
  for (double y = std::min(a.y, b.y); y < std::max(a.br().y, b.br().y); y += step)
    for (double x = std::min(a.x, b.x); x < std::max(a.br().x, b.br().x); x += step)
      if (std::hypot(x - ax, y - ay) < r1 && std::hypot(x - bx, y - by) < r2) ++both;
  return both * step * step / (std::numbers::pi * std::min(r1, r2) * std::min(r1, r2));
}

TEST(BowlNms, InscribedCircleOverlap) {
  EXPECT_DOUBLE_EQ(inscribedCircleOverlap({0, 0, 20, 20}, {0, 0, 20, 20}), 1.0);
  EXPECT_DOUBLE_EQ(inscribedCircleOverlap({0, 0, 20, 20}, {40, 0, 20, 20}), 0.0);
  // Boxes touching corners overlap as boxes but their circles do not.
  EXPECT_DOUBLE_EQ(inscribedCircleOverlap({0, 0, 20, 20}, {15, 15, 20, 20}), 0.0);
  // A small circle inside a large one: 100% of the smaller.
  EXPECT_DOUBLE_EQ(inscribedCircleOverlap({0, 0, 100, 100}, {40, 40, 20, 20}), 1.0);
  // The circle of a wide box has the box's height as diameter.
  // (centre (30, 10), r = 10): the same circle as a centred 20x20 box, disjoint from one at x = 0.
  EXPECT_DOUBLE_EQ(inscribedCircleOverlap({0, 0, 60, 20}, {20, 0, 20, 20}), 1.0);
  EXPECT_DOUBLE_EQ(inscribedCircleOverlap({0, 0, 60, 20}, {0, 0, 20, 20}), 0.0);
  for (const auto& [a, b] : {std::pair{cv::Rect(0, 0, 40, 40), cv::Rect(25, 5, 40, 40)},
                             std::pair{cv::Rect(0, 0, 40, 40), cv::Rect(10, 10, 30, 30)},
                             std::pair{cv::Rect(0, 0, 60, 40), cv::Rect(30, 20, 20, 20)}})
    EXPECT_NEAR(inscribedCircleOverlap(a, b), numericOverlap(a, b), 0.01);  // grid error < 1%
}

TEST(BowlNms, DistinctBelowTenPercentSuppressedAbove) {
  // Equal circles r = 20: centre distance 33 -> 8.6% overlap (distinct), 25 -> 22% (same).
  const cv::Rect a(0, 0, 40, 40);
  ASSERT_LT(inscribedCircleOverlap(a, {33, 0, 40, 40}), 0.10);
  ASSERT_GT(inscribedCircleOverlap(a, {25, 0, 40, 40}), 0.10);
  auto kept = suppressNonMaxima({{{33, 0, 40, 40}, 1.0, "top"}, {a, 2.0, "middle"}}, 0.10);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].box, a);  // highest response first
  kept = suppressNonMaxima(
      {{{25, 0, 40, 40}, 1.0, "side"}, {a, 2.0, "middle"}, {{200, 0, 40, 40}, 0.5, "top"}}, 0.10);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].box, a);
  EXPECT_EQ(kept[0].view, "middle");
  EXPECT_EQ(kept[1].box, cv::Rect(200, 0, 40, 40));
}

TEST(BowlNms, MergedBoxIsTheMeanOfTheKeptWindowsNeighbours) {
  // The best window is too small for the object; two neighbours at other scales straddle it.
  // A distant window is neither merged nor merges.
  const std::vector<BowlDetection> windows = {{{10, 10, 40, 20}, 3.0, "side"},
                                              {{6, 8, 60, 30}, 2.0, "side"},
                                              {{8, 6, 50, 34}, 1.5, "middle"},
                                              {{300, 10, 40, 20}, 1.0, "side"}};
  ASSERT_GE(boxIoU(windows[0].box, windows[1].box), 0.3);
  ASSERT_GE(boxIoU(windows[0].box, windows[2].box), 0.3);
  const auto kept = suppressNonMaxima(windows, 0.10, 0.3);
  ASSERT_EQ(kept.size(), 2u);
  // Corners: left (10+6+8)/3 = 8, top (10+8+6)/3 = 8, right (50+66+58)/3 = 58, bottom (30+38+40)/3
  // = 36.
  EXPECT_EQ(kept[0].box, cv::Rect(8, 8, 50, 28));
  EXPECT_DOUBLE_EQ(kept[0].score, 3.0);  // score and view stay the kept window's
  EXPECT_EQ(kept[0].view, "side");
  EXPECT_EQ(kept[1].box, cv::Rect(300, 10, 40, 20));
  // 0 = no merging: the kept window's own box.
  EXPECT_EQ(suppressNonMaxima(windows, 0.10, 0.0)[0].box, windows[0].box);
}

TEST(BowlNms, SupportBonusReRanksWithoutChangingWhatIsKept) {
  // A lone window (a look-alike) outscores each of three overlapping windows on one object;
  // with the bonus, the supported object ranks first: 3.0 + 2 ln 3 = 5.197 > 4.0.
  const std::vector<BowlDetection> windows = {{{300, 10, 40, 20}, 4.0, "side"},
                                              {{10, 10, 40, 20}, 3.0, "side"},
                                              {{6, 8, 60, 30}, 2.0, "side"},
                                              {{8, 6, 50, 34}, 1.5, "middle"}};
  const auto plain = suppressNonMaxima(windows, 0.10, 0.3, 0.0);
  const auto supported = suppressNonMaxima(windows, 0.10, 0.3, 2.0);
  ASSERT_EQ(plain.size(), 2u);
  ASSERT_EQ(supported.size(), 2u);
  EXPECT_EQ(plain[0].box, cv::Rect(300, 10, 40, 20));
  EXPECT_DOUBLE_EQ(plain[0].score, 4.0);
  EXPECT_EQ(supported[0].box, cv::Rect(8, 8, 50, 28));  // the merged box, as without the bonus
  EXPECT_NEAR(supported[0].score, 3.0 + 2.0 * std::log(3.0), 1e-12);
  EXPECT_EQ(supported[0].view, "side");
  EXPECT_EQ(supported[1].box, cv::Rect(300, 10, 40, 20));
  EXPECT_DOUBLE_EQ(supported[1].score, 4.0);  // ln 1 = 0: a lone window gains nothing
}

}  // namespace
}  // namespace shapesense
