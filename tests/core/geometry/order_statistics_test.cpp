// Quantiles and trimmed ranges (core/geometry/order_statistics.h) against a full sort, and
// quantiles of bucket counts.

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
