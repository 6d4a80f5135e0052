// PlaneMoments' distances to a given plane against the same sums taken point by point.

#include <gtest/gtest.h>

#include <cmath>

#include "shapesense/core/geometry/plane_fitting.h"

namespace shapesense {
namespace {

TEST(PlaneMoments, MeanSquaredDistanceToAGivenPlane) {
  // Points 1 cm in front of and behind the plane z = 2 (n = (0, 0, -1), d = 2), and 3 cm off a
  // tilted plane on average.
  PlaneMoments moments;
  const Eigen::Vector3d tilted = Eigen::Vector3d(0.2, -0.1, -1.0).normalized();
  double sum_tilted = 0.0;
  int count = 0;
  for (double x = -0.5; x <= 0.5; x += 0.1)
    for (double y = -0.4; y <= 0.4; y += 0.1) {
      const Eigen::Vector3d p(x, y, 2.0 + (count % 2 ? 0.01 : -0.01));
      moments.add(p);
      const double distance = tilted.dot(p) + 2.1;
      sum_tilted += distance * distance;
      ++count;
    }
  EXPECT_NEAR(moments.meanSquaredDistance({0, 0, -1}, 2.0), 1e-4, 1e-9);
  EXPECT_NEAR(moments.meanSquaredDistance(tilted, 2.1), sum_tilted / count, 1e-9);
  EXPECT_EQ(PlaneMoments().meanSquaredDistance({0, 0, -1}, 2.0), 0.0);
}

}  // namespace
}  // namespace shapesense
