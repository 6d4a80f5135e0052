// MomentSums: the sums PlaneMoments makes, and the height-field slopes taken from them.

#include "shapesense/core/geometry/moment_sums.h"

#include <gtest/gtest.h>

namespace shapesense {
namespace {

TEST(MomentSums, MomentsEqualThoseOfTheSameAdds) {
  const cv::Vec3f points[] = {
      {0.1f, 0.2f, 1.0f}, {0.3f, -0.1f, 1.2f}, {-0.2f, 0.0f, 0.9f}, {0.0f, 0.4f, 1.1f}};
  PlaneMoments direct;
  MomentSums sums(Eigen::Vector3d(0.1, 0.2, 1.0));  // the first point, as add() takes it
  for (const cv::Vec3f& p : points) {
    direct.add(p[0], p[1], p[2]);
    sums.add(p);
  }
  const PlaneFit a = direct.fit(), b = sums.moments().fit();
  ASSERT_TRUE(a.valid && b.valid);
  EXPECT_NEAR(a.normal.dot(b.normal), 1.0, 1e-12);
  EXPECT_NEAR(a.d, b.d, 1e-12);
  EXPECT_EQ(sums.count(), 4.0);
}

// Heights c = 0.3 a - 0.2 b + 1 with a small alternating ripple: the slopes come back.
TEST(MomentSums, HeightSlopesOfATiltedGrid) {
  MomentSums sums(Eigen::Vector3d::Zero());
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) {
      const double a = 0.01 * i, b = 0.01 * j, ripple = ((i + j) % 2 ? 1e-5 : -1e-5);
      sums.addOffset(a, b, 0.3 * a - 0.2 * b + 1.0 + ripple);
    }
  const auto slopes = sums.heightSlopes();
  ASSERT_TRUE(slopes.has_value());
  EXPECT_NEAR(slopes->x(), 0.3, 1e-3);
  EXPECT_NEAR(slopes->y(), -0.2, 1e-3);
}

TEST(MomentSums, NoHeightSlopesOnALineOrWithTooFewPoints) {
  MomentSums line(Eigen::Vector3d::Zero());
  for (int i = 0; i < 6; ++i) line.addOffset(0.01 * i, 0.02 * i, 0.005 * i);
  EXPECT_FALSE(line.heightSlopes().has_value());
  MomentSums two(Eigen::Vector3d::Zero());
  two.addOffset(0.0, 0.0, 1.0);
  two.addOffset(0.01, 0.02, 1.0);
  EXPECT_FALSE(two.heightSlopes().has_value());
}

}  // namespace
}  // namespace shapesense
