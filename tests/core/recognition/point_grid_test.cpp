// The cube grid's neighbourhoods and the k-d tree's bounded nearest point
// (recognition/cloud_index.h) against a brute-force search, for radii within one cube side and
// beyond it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "../../../core/src/recognition/cloud_index.h"

namespace shapesense::detail {
namespace {

// A bent sheet (two faces meeting at a crease) and a scatter of loose points, in a 20 cm box.
std::vector<Eigen::Vector3f> testPoints() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 3000; ++i) {
    const float u = 0.2f * unit(rng);
    const float v = 0.2f * unit(rng);
    points.emplace_back(u - 0.1f, v - 0.1f, 1.0f + 0.5f * std::abs(u - 0.1f));
  }
  for (int i = 0; i < 500; ++i) {
    const float x = 0.2f * unit(rng) - 0.1f;
    const float y = 0.2f * unit(rng) - 0.1f;
    const float z = 0.2f * unit(rng) + 0.95f;
    points.emplace_back(x, y, z);
  }
  return points;
}

std::vector<std::uint32_t> bruteForce(const std::vector<Eigen::Vector3f>& points,
                                      const Eigen::Vector3f& query, float radius) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t i = 0; i < points.size(); ++i)
    if ((points[i] - query).squaredNorm() <= radius * radius) out.push_back(i);
  return out;
}

std::vector<std::uint32_t> sorted(std::vector<std::uint32_t> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(PointGrid, EveryPointsNeighbourhoodIsTheBruteForceOne) {
  const std::vector<Eigen::Vector3f> points = testPoints();
  const PointGrid grid(points, 0.015f);
  for (float radius : {0.01f, 0.015f, 0.035f}) {
    std::size_t visited = 0, total_neighbours = 0;
    grid.forEachPoint(radius, {}, [&](std::uint32_t i, const std::vector<std::uint32_t>& found) {
      ++visited;
      total_neighbours += found.size();
      ASSERT_EQ(sorted(found), bruteForce(points, points[i], radius)) << "point " << i;
    });
    EXPECT_EQ(visited, points.size());
    EXPECT_GT(total_neighbours, 3 * points.size());  // the test has neighbours to find
  }
}

TEST(PointGrid, VisitsOnlyTheWantedPoints) {
  const std::vector<Eigen::Vector3f> points = testPoints();
  const PointGrid grid(points, 0.015f);
  std::vector<std::uint8_t> wanted(points.size(), 0);
  for (std::size_t i = 0; i < wanted.size(); i += 7) wanted[i] = 1;
  std::vector<std::uint8_t> seen(points.size(), 0);
  grid.forEachPoint(0.015f, wanted,
                    [&](std::uint32_t i, const std::vector<std::uint32_t>&) { ++seen[i]; });
  EXPECT_EQ(seen, wanted);
}

TEST(PointGrid, QueriesAnywhereMatchBruteForce) {
  const std::vector<Eigen::Vector3f> points = testPoints();
  const PointGrid grid(points, 0.015f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> coordinate(-0.12f, 0.12f);
  std::vector<std::uint32_t> found;
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3f query(coordinate(rng), coordinate(rng), 1.05f + coordinate(rng));
    for (float radius : {0.015f, 0.035f}) {
      grid.withinRadius(query, radius, found);
      EXPECT_EQ(sorted(found), bruteForce(points, query, radius));
    }
  }
}

// pointsByCell against a sort of (key, index) pairs: for a table-top cloud (a radix sort on
// the cells' offsets) and for one spread over 40 m (too many cells for that: a plain sort).
TEST(PointGrid, PointsByCellIsTheOrderOfSortedKeyIndexPairs) {
  std::mt19937 rng(3);
  for (const float extent : {0.3f, 40.0f}) {
    std::uniform_real_distribution<float> coordinate(-extent / 2, extent / 2);
    std::vector<Eigen::Vector3f> points;
    for (int i = 0; i < 20000; ++i)
      points.emplace_back(coordinate(rng), coordinate(rng), 2.0f + coordinate(rng));
    // Duplicated cells in reverse index order: their entries must come out by index.
    for (int i = 0; i < 500; ++i) points.push_back(points[static_cast<std::size_t>(499 - i)]);
    std::vector<std::pair<std::int64_t, std::uint32_t>> expected;
    for (std::uint32_t i = 0; i < points.size(); ++i)
      expected.emplace_back(cellKey(cellOf(points[i], 0.005f)), i);
    std::sort(expected.begin(), expected.end());
    const std::vector<CellEntry> found = pointsByCell(points, 0.005f);
    ASSERT_EQ(found.size(), expected.size());
    for (std::size_t k = 0; k < found.size(); ++k) {
      ASSERT_EQ(found[k].key, expected[k].first) << "extent " << extent << " entry " << k;
      ASSERT_EQ(found[k].index, expected[k].second) << "extent " << extent << " entry " << k;
    }
  }
  EXPECT_TRUE(pointsByCell({}, 0.005f).empty());
}

TEST(PointGrid, EmptyCloud) {
  const std::vector<Eigen::Vector3f> none;
  const PointGrid grid(none, 0.015f);
  std::vector<std::uint32_t> found{1, 2};
  grid.withinRadius(Eigen::Vector3f(0, 0, 1), 0.02f, found);
  EXPECT_TRUE(found.empty());
  EXPECT_EQ(grid.cubeCount(), 0u);
}

// The nearest point within a bound, by brute force: -1 when none is.
int bruteNearestWithin(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& query,
                       float bound) {
  int best = -1;
  float best2 = bound * bound;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float d2 = (points[i] - query).squaredNorm();
    if (d2 < best2 || (best < 0 && d2 == best2)) {
      best = static_cast<int>(i);
      best2 = d2;
    }
  }
  return best;
}

TEST(CloudIndex, TheNearestPointWithinABoundIsTheBruteForceOne) {
  const std::vector<Eigen::Vector3f> points = testPoints();
  const CloudIndex index_2mm(points, 0.002f), index_1cm(points, 0.01f), index_5cm(points, 0.05f);
  const std::pair<const CloudIndex*, float> indices[] = {
      {&index_2mm, 0.002f}, {&index_1cm, 0.01f}, {&index_5cm, 0.05f}};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> coordinate(-0.12f, 0.12f);
  int found = 0, none = 0;
  for (int q = 0; q < 500; ++q) {
    const Eigen::Vector3f query(coordinate(rng), coordinate(rng), 1.05f + coordinate(rng));
    for (const auto& [index, bound] : indices) {
      float d2 = -1.0f;
      const int j = index->nearestWithin(query, d2);
      const int expected = bruteNearestWithin(points, query, bound);
      ASSERT_EQ(j < 0, expected < 0) << "query " << q << " bound " << bound;
      if (j < 0) {
        ++none;
        continue;
      }
      ++found;
      EXPECT_FLOAT_EQ(d2, (points[static_cast<std::size_t>(expected)] - query).squaredNorm());
      EXPECT_LE(d2, bound * bound);
    }
  }
  EXPECT_GT(found, 100);  // both outcomes occur
  EXPECT_GT(none, 100);
}

TEST(CloudIndex, ACloudSpreadFarForItsBoundStillGivesTheNearestPoint) {
  // 2 km across with a 1 cm bound: the cubes grow past half the bound, the answers stay exact.
  std::vector<Eigen::Vector3f> points = testPoints();
  points.emplace_back(-1000.0f, 5.0f, 3.0f);
  points.emplace_back(1000.0f, -5.0f, 900.0f);
  const CloudIndex index(points, 0.01f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> coordinate(-0.12f, 0.12f);
  for (int q = 0; q < 300; ++q) {
    const Eigen::Vector3f query(coordinate(rng), coordinate(rng), 1.05f + coordinate(rng));
    float d2 = -1.0f;
    const int j = index.nearestWithin(query, d2);
    const int expected = bruteNearestWithin(points, query, 0.01f);
    ASSERT_EQ(j < 0, expected < 0) << "query " << q;
    if (j >= 0) {
      EXPECT_FLOAT_EQ(d2, (points[static_cast<std::size_t>(expected)] - query).squaredNorm());
    }
  }
  float d2 = 0.0f;
  EXPECT_EQ(index.nearestWithin(Eigen::Vector3f(1000.0f, -5.0f, 900.005f), d2),
            static_cast<int>(points.size()) - 1);
  EXPECT_EQ(index.nearestWithin(Eigen::Vector3f(1e20f, 0.0f, 1.0f), d2), -1);
  EXPECT_EQ(index.nearestWithin(Eigen::Vector3f(std::nanf(""), 0.0f, 1.0f), d2), -1);
}

TEST(CloudIndex, AnEmptyCloudHasNoNearestPoint) {
  const std::vector<Eigen::Vector3f> none;
  const CloudIndex index(none, 1.0f);
  float d2 = 0.0f;
  EXPECT_EQ(index.nearestWithin(Eigen::Vector3f(0, 0, 1), d2), -1);
}

}  // namespace
}  // namespace shapesense::detail
