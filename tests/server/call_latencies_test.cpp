// The daemon's account of how long it took to answer calls (GetStatus serves it: see
// get_status_test.cpp).

#include "shapesense/server/call_latencies.h"

#include <numeric>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

std::uint64_t total(const std::vector<std::uint64_t>& counts) {
  return std::accumulate(counts.begin(), counts.end(), std::uint64_t{0});
}

TEST(CallLatencies, CountsAnsweredCallsByBucketAndRefusedAndFailedOnes) {
  CallLatencies latencies;
  latencies.record("/shapesense.v1.ShapeSense/EstimateBox", grpc::StatusCode::OK, 0.1);
  latencies.record("/shapesense.v1.ShapeSense/EstimateBox", grpc::StatusCode::OK, 4.0);
  latencies.record("/shapesense.v1.ShapeSense/EstimateBox", grpc::StatusCode::OK, 1000.0);
  latencies.record("/shapesense.v1.ShapeSense/EstimateBox", grpc::StatusCode::RESOURCE_EXHAUSTED,
                   6.0);
  latencies.record("EstimateBox", grpc::StatusCode::INVALID_ARGUMENT, 0.2);
  latencies.record("/shapesense.v1.ShapeSense/GetPlanes", grpc::StatusCode::OK, 7.5);
  const auto methods = latencies.snapshot();
  ASSERT_EQ(methods.size(), 2u);
  const MethodLatency& box = methods[0];
  EXPECT_EQ(box.method, "EstimateBox");
  EXPECT_EQ(box.answered, 3u);
  EXPECT_EQ(box.refused, 1u);
  EXPECT_EQ(box.failed, 1u);
  ASSERT_EQ(box.answered_by_bucket.size(), MethodLatency::kBucketUpperMs.size() + 1);
  EXPECT_EQ(total(box.answered_by_bucket), 3u);
  EXPECT_EQ(box.answered_by_bucket.front(), 1u);  // 0.1 ms: up to 0.25
  EXPECT_EQ(box.answered_by_bucket.back(), 1u);   // 1 s: above the last bound
  EXPECT_EQ(box.answered_by_bucket[5], 1u);       // 4 ms: (3, 5]
  EXPECT_EQ(MethodLatency::kBucketUpperMs[5], 5.0);
  const MethodLatency& planes = methods[1];
  EXPECT_EQ(planes.method, "GetPlanes");
  EXPECT_EQ(planes.answered_by_bucket[6], 1u);  // 7.5 ms: a bound belongs to its bucket
}

}  // namespace
}  // namespace shapesense
