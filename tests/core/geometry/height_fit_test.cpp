// The height fit against surfaces of known curvature: a quadric's curvature at its vertex is
// 1 / radius for a sphere and for a cylinder across its axis, 0 for a plane.

#include "shapesense/core/geometry/height_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace shapesense {
namespace {

// Points of a patch seen from z = 0 at range `range`: (x, y, range + depth(x, y)) on a grid
// of half-width `half` metres, with Gaussian noise of `noise` metres along z.
template <typename Depth>
HeightSums patch(double range, double half, double noise, const Depth& depth) {
  HeightSums sums(Eigen::Vector3d(0, 0, -1));
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0.0, noise);
  for (double x = -half; x <= half; x += half / 20)
    for (double y = -half; y <= half; y += half / 20)
      sums.add({x + 0.3, y - 0.2, range + depth(x, y) + gauss(rng)});
  return sums;
}

TEST(HeightFit, APlaneFitsAsWellAsAQuadricAndDoesNotBend) {
  const HeightFit fit =
      fitHeights(patch(1.5, 0.1, 0.002, [](double x, double y) { return 0.3 * x - 0.1 * y; }));
  ASSERT_TRUE(fit.reliable());
  EXPECT_NEAR(fit.planeRms(), 0.002, 0.0003);
  EXPECT_LT(fit.planeToQuadricRms(), 1.05);
  EXPECT_LT(fit.curvature, 0.5);  // noise alone: 2 mm over 20 cm bends by well under 1 /m
}

TEST(HeightFit, ASphereCapBendsByOneOverItsRadius) {
  const double r = 0.1;
  const HeightFit fit = fitHeights(patch(1.0, 0.03, 0.0, [r](double x, double y) {
    return r - std::sqrt(r * r - x * x - y * y);  // nearest point at the centre
  }));
  ASSERT_TRUE(fit.reliable());
  EXPECT_NEAR(fit.curvature, 1.0 / r, 0.05 / r);
  EXPECT_GT(fit.planeToQuadricRms(), 10.0);
}

TEST(HeightFit, ACylinderBendsAcrossItsAxisOnly) {
  const double r = 0.05;
  const HeightFit fit = fitHeights(
      patch(0.8, 0.02, 0.0, [r](double x, double) { return r - std::sqrt(r * r - x * x); }));
  ASSERT_TRUE(fit.reliable());
  EXPECT_NEAR(fit.curvature, 1.0 / r, 0.05 / r);
}

TEST(HeightFit, TooFewPointsGiveNoFit) {
  HeightSums sums(Eigen::Vector3d::UnitZ());
  for (int i = 0; i < 5; ++i) sums.add({0.1 * i, 0.0, 1.0});
  const HeightFit fit = fitHeights(sums);
  EXPECT_FALSE(fit.reliable());
  EXPECT_EQ(fit.count, 0);
  EXPECT_EQ(fit.curvature, 0.0);
}

}  // namespace
}  // namespace shapesense
