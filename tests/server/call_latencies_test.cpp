// The daemon's account of how long it took to answer calls: CallLatencies, and GetStatus
// serving it through a real in-process gRPC server.

#include "shapesense/server/call_latencies.h"

#include <numeric>

#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense {
namespace {

using testing::clientContext;
using testing::TestServer;

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

TEST(GetStatus, ReportsTheCallsTheDaemonAnsweredAndFailedByMethod) {
  TestServer srv;
  srv.addMany(3);
  v1::EstimateBoxRequest box;  // no ROI: INVALID_ARGUMENT
  v1::EstimateBoxResponse box_response;
  EXPECT_EQ(srv.stub().EstimateBox(clientContext().get(), box, &box_response).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  v1::ListFramesResponse frames;
  ASSERT_TRUE(srv.stub().ListFrames(clientContext().get(), {}, &frames).ok());
  ASSERT_TRUE(srv.stub().ListFrames(clientContext().get(), {}, &frames).ok());
  v1::GetStatusResponse status;
  ASSERT_TRUE(srv.stub().GetStatus(clientContext().get(), {}, &status).ok());
  std::map<std::string, v1::CallLatency> calls;
  for (const auto& call : status.calls()) calls[call.method()] = call;
  ASSERT_EQ(calls.count("EstimateBox"), 1u);
  EXPECT_EQ(calls["EstimateBox"].answered(), 0u);
  EXPECT_EQ(calls["EstimateBox"].failed(), 1u);
  ASSERT_EQ(calls.count("ListFrames"), 1u);
  const v1::CallLatency& listed = calls["ListFrames"];
  EXPECT_EQ(listed.answered(), 2u);
  EXPECT_EQ(listed.refused(), 0u);
  ASSERT_EQ(listed.bucket_upper_ms_size() + 1, listed.answered_by_bucket_size());
  std::uint64_t counted = 0;
  for (const auto n : listed.answered_by_bucket()) counted += n;
  EXPECT_EQ(counted, 2u);
  // The GetStatus call itself is counted once its answer is sent, so not in its own answer.
  EXPECT_EQ(calls.count("GetStatus"), 0u);
}

}  // namespace
}  // namespace shapesense
