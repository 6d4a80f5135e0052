// The implicit quadric surface fit against surfaces that are quadrics at any extent (a sphere's
// half seen from its side, a cylinder across half its girth), against points that lie on no one
// quadric (a sphere beside a cylinder), and against the height-field quadric that fits such a
// view only in a cap.

#include "shapesense/core/geometry/quadric_surface.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "shapesense/core/geometry/height_fit.h"

namespace shapesense {
namespace {

// The half of a sphere of radius r centred at `centre` that faces the camera at the origin
// (points whose outward normal has z < 0), with Gaussian noise of `noise` m along the line of
// sight.
std::vector<Eigen::Vector3d> sphereHalf(const Eigen::Vector3d& centre, double r, double noise) {
  std::vector<Eigen::Vector3d> points;
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0.0, noise);
  for (double polar = 0.05; polar < M_PI / 2; polar += 0.05)
    for (double azimuth = 0.0; azimuth < 2 * M_PI; azimuth += 0.1) {
      const Eigen::Vector3d outward(std::sin(polar) * std::cos(azimuth),
                                    std::sin(polar) * std::sin(azimuth), -std::cos(polar));
      const Eigen::Vector3d x = centre + r * outward;
      points.push_back(x * (1.0 + gauss(rng) / x.norm()));
    }
  return points;
}

// The half of an upright cylinder (axis along y) of radius r about `centre` that faces the
// camera, 20 cm tall.
std::vector<Eigen::Vector3d> cylinderHalf(const Eigen::Vector3d& centre, double r) {
  std::vector<Eigen::Vector3d> points;
  for (double angle = 0.05; angle < M_PI; angle += 0.05)
    for (double y = -0.1; y <= 0.1; y += 0.01)
      points.push_back(centre + Eigen::Vector3d(r * std::cos(angle), y, -r * std::sin(angle)));
  return points;
}

TEST(QuadricSurface, ASphereSeenAcrossItsWholeHalfLiesOnOne) {
  const auto points = sphereHalf({0.1, 0.0, 1.2}, 0.12, 0.0);
  const QuadricSurfaceFit fit = fitQuadricSurface({points});
  ASSERT_TRUE(fit.reliable());
  EXPECT_LT(fit.rms_m, 1e-6);
}

TEST(QuadricSurface, NoiseAlongTheLineOfSightIsWhatRemains) {
  const auto points = sphereHalf({0.1, 0.0, 1.2}, 0.12, 0.002);
  const QuadricSurfaceFit fit = fitQuadricSurface({points});
  ASSERT_TRUE(fit.reliable());
  EXPECT_GT(fit.rms_m, 0.0005);
  EXPECT_LT(fit.rms_m, 0.003);
}

TEST(QuadricSurface, ACylinderAcrossHalfItsGirthLiesOnOne) {
  const QuadricSurfaceFit fit = fitQuadricSurface({cylinderHalf({-0.2, 0.0, 1.5}, 0.08)});
  ASSERT_TRUE(fit.reliable());
  EXPECT_LT(fit.rms_m, 1e-6);
}

TEST(QuadricSurface, TheHeightFieldQuadricFitsSuchAViewOnlyRoughly) {
  const auto points = sphereHalf({0.1, 0.0, 1.2}, 0.12, 0.0);
  HeightSums heights(Eigen::Vector3d(0, 0, -1));
  for (const Eigen::Vector3d& x : points) heights.add(x);
  EXPECT_GT(fitHeights(heights).quadricRms(), 0.005);
}

TEST(QuadricSurface, ASphereBesideACylinderLieOnNoOne) {
  const auto sphere = sphereHalf({0.1, 0.0, 1.2}, 0.12, 0.0);
  const auto cylinder = cylinderHalf({-0.2, 0.0, 1.3}, 0.08);
  const QuadricSurfaceFit both = fitQuadricSurface({sphere, cylinder});
  ASSERT_TRUE(both.reliable());
  EXPECT_GT(both.rms_m, 0.005);
}

TEST(QuadricSurface, TwoPiecesOfOneSphereLieOnOne) {
  const auto points = sphereHalf({0.1, 0.0, 1.2}, 0.12, 0.0);
  const std::vector<Eigen::Vector3d> left(points.begin(), points.begin() + points.size() / 2);
  const std::vector<Eigen::Vector3d> right(points.begin() + points.size() / 2, points.end());
  const QuadricSurfaceFit both = fitQuadricSurface({left, right}, 200);
  ASSERT_TRUE(both.reliable());
  EXPECT_LE(both.count, 200);
  EXPECT_LT(both.rms_m, 1e-6);
}

TEST(QuadricSurface, OnePointRepeatedGivesNoFit) {
  const std::vector<Eigen::Vector3d> points(50, Eigen::Vector3d(0.1, 0.2, 1.0));
  const QuadricSurfaceFit fit = fitQuadricSurface({points});
  EXPECT_FALSE(fit.reliable());
}

TEST(QuadricSurface, TooFewPointsGiveNoFit) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 12; ++i) points.push_back({0.01 * i, 0.02 * (i % 3), 1.0 + 0.001 * i * i});
  EXPECT_FALSE(fitQuadricSurface({points}).reliable());
  EXPECT_FALSE(fitQuadricSurface({}).reliable());
}

}  // namespace
}  // namespace shapesense
