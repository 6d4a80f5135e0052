// Quantiles and trimmed ranges (core/geometry/order_statistics.h) against a full sort, dense
// ranges, and quantiles of bucket counts.

#include "shapesense/core/geometry/order_statistics.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

std::pair<double, double> sortedTrimmedRange(std::vector<double> values, double trim) {
  std::sort(values.begin(), values.end());
  const auto low = static_cast<std::size_t>(std::floor(trim * static_cast<double>(values.size())));
  return {values[low], values[values.size() - 1 - low]};
}

TEST(TrimmedRange, IsTheSortedRangeAfterDroppingTheTrimAtEachEnd) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(1.5, 0.2);
  std::uniform_real_distribution<double> uniform(-3.0, 3.0);
  for (const std::size_t n : {1u, 2u, 5u, 499u, 500u, 501u, 20'000u, 200'000u}) {
    for (const double trim : {0.0, 0.002, 0.01, 0.2, 0.49}) {
      std::vector<double> values(n);
      // Gaussian bulk plus far outliers: the histogram's bins are wide where the ranks fall.
      for (std::size_t i = 0; i < n; ++i)
        values[i] = i % 97 == 0 ? 40.0 * uniform(rng) : normal(rng);
      EXPECT_EQ(trimmedRange(values, trim), sortedTrimmedRange(values, trim))
          << "n " << n << " trim " << trim;
    }
  }
}

TEST(TrimmedRange, RepeatedValuesAndAllEqual) {
  std::vector<double> values(10'000, 2.0);
  EXPECT_EQ(trimmedRange(values, 0.1), std::make_pair(2.0, 2.0));
  // Two values only, many of each: the ranks fall in the first and last bins.
  for (std::size_t i = 0; i < values.size(); i += 3) values[i] = -1.0;
  EXPECT_EQ(trimmedRange(values, 0.1), sortedTrimmedRange(values, 0.1));
  EXPECT_EQ(trimmedRange(values, 0.4), sortedTrimmedRange(values, 0.4));
}

TEST(DenseRange, LeavesOutStragglersPastAGap) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> body(1.0, 1.2);
  std::vector<double> values;
  for (int i = 0; i < 2000; ++i) values.push_back(body(rng));
  // A sparse trail behind the body, 10 cm apart, and one far value.
  for (double v = 1.4; v < 2.5; v += 0.1) values.push_back(v);
  values.push_back(4.0);
  const auto [low, high] = denseRange(values, 0.03, 0.2);
  EXPECT_EQ(low, *std::min_element(values.begin(), values.begin() + 2000));
  EXPECT_EQ(high, *std::max_element(values.begin(), values.begin() + 2000));
}

TEST(DenseRange, KeepsEveryClusterHoldingTheShareAndTheMediansOwn) {
  std::vector<double> values;
  for (int i = 0; i < 700; ++i) values.push_back(1.0 + 0.0001 * i);  // 1.0 .. 1.07, the median
  for (int i = 0; i < 250; ++i) values.push_back(2.0 + 0.0001 * i);  // a quarter: kept
  for (int i = 0; i < 50; ++i) values.push_back(0.5 + 0.0001 * i);   // a twentieth: left out
  EXPECT_EQ(denseRange(values, 0.03, 0.2), std::make_pair(1.0, 2.0 + 0.0001 * 249));
  // Asking for a larger share leaves out the quarter; no share keeps everything.
  EXPECT_EQ(denseRange(values, 0.03, 0.3), std::make_pair(1.0, 1.0 + 0.0001 * 699));
  EXPECT_EQ(denseRange(values, 0.03, 0.0), std::make_pair(0.5, 2.0 + 0.0001 * 249));
}

TEST(DenseRange, AGapNarrowerThanHalfTheLimitNeverCuts) {
  // Evenly spaced 1 cm apart: no empty bin of 2 cm (half a 4 cm limit) can fall between two.
  std::vector<double> values;
  for (int i = 0; i < 100; ++i) values.push_back(0.01 * i);
  EXPECT_EQ(denseRange(values, 0.04, 0.5), std::make_pair(0.0, 0.99));
  const std::vector<double> one{3.0};
  EXPECT_EQ(denseRange(one, 0.04, 0.5), std::make_pair(3.0, 3.0));
}

TEST(Quantile, IsTheValueAtItsRank) {
  std::vector<double> values{5.0, 1.0, 4.0, 2.0, 3.0};
  EXPECT_EQ(quantile(values, 0.0), 1.0);
  EXPECT_EQ(quantile(values, 0.5), 3.0);
  EXPECT_EQ(quantile(values, 1.0), 5.0);
  EXPECT_EQ(quantile(values, 0.74), 3.0);  // rank floor(0.74 * 4) = 2
}

TEST(BucketQuantile, IsTheUpperBoundOfTheBucketWhereTheShareIsReached) {
  const std::vector<double> bounds{1, 2, 5};
  // 10 values up to 1, 80 in (1, 2], 9 in (2, 5], 1 above 5.
  const std::vector<std::uint64_t> counts{10, 80, 9, 1};
  EXPECT_EQ(bucketQuantile(bounds, counts, 0.0), 1.0);
  EXPECT_EQ(bucketQuantile(bounds, counts, 0.10), 1.0);
  EXPECT_EQ(bucketQuantile(bounds, counts, 0.11), 2.0);
  EXPECT_EQ(bucketQuantile(bounds, counts, 0.90), 2.0);
  EXPECT_EQ(bucketQuantile(bounds, counts, 0.99), 5.0);
  EXPECT_EQ(bucketQuantile(bounds, counts, 1.0), std::numeric_limits<double>::infinity());
}

TEST(BucketQuantile, NothingCountedIsZero) {
  const std::vector<double> bounds{1, 2};
  EXPECT_EQ(bucketQuantile(bounds, std::vector<std::uint64_t>{0, 0, 0}, 0.5), 0.0);
}

}  // namespace
}  // namespace shapesense
