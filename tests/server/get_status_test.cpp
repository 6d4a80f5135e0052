// GetStatus through a real in-process gRPC server.

#include <atomic>
#include <map>
#include <thread>

#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense {
namespace {

using testing::clientContext;
using testing::kFramePeriodNs;
using testing::kServerT0;
using testing::TestServer;

PipelineStatus knownStatus(SourceState state) {
  PipelineStatus s;
  s.source = "tum:/data/desk";
  s.state = state;
  s.last_error = "/data/desk/depth/3.png: missing depth image";
  s.frames_received = 1234;
  s.frames_processed = 1000;
  s.frames_skipped = 234;
  s.source_errors = 7;
  s.frames_out_of_order = 5;
  s.health.disconnects = 3;
  s.stages = {{"depth_stats", 1000, 1.5, 1.25, 2.75}, {"total", 1000, 1.75, 1.5, 3.0}};
  s.detectors = {"depth_stats"};
  return s;
}

TEST(GetStatus, ReportsThePipelineCountersAndTheCacheRange) {
  TestServer srv(8, [] { return knownStatus(SourceState::kStreaming); });
  srv.addMany(10);  // capacity 8: frames 2..9 remain
  v1::GetStatusResponse response;
  auto context = clientContext();
  const grpc::Status status =
      srv.stub().GetStatus(context.get(), v1::GetStatusRequest{}, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_FALSE(response.version().empty());
  EXPECT_EQ(response.source(), "tum:/data/desk");
  EXPECT_EQ(response.source_state(), v1::GetStatusResponse::STREAMING);
  EXPECT_EQ(response.source_message(), "/data/desk/depth/3.png: missing depth image");
  EXPECT_EQ(response.frames_received(), 1234u);
  EXPECT_EQ(response.frames_processed(), 1000u);
  EXPECT_EQ(response.frames_skipped(), 234u);
  EXPECT_EQ(response.source_errors(), 7u);
  EXPECT_EQ(response.frames_out_of_order(), 5u);
  EXPECT_EQ(response.source_disconnects(), 3u);
  EXPECT_EQ(response.cache().frames(), 8u);
  EXPECT_EQ(response.cache().capacity(), 8u);
  EXPECT_EQ(response.cache().oldest_ns(), kServerT0 + 2 * kFramePeriodNs);
  EXPECT_EQ(response.cache().newest_ns(), kServerT0 + 9 * kFramePeriodNs);
  ASSERT_EQ(response.stages_size(), 2);
  EXPECT_EQ(response.stages(0).stage(), "depth_stats");
  EXPECT_EQ(response.stages(0).runs(), 1000u);
  EXPECT_DOUBLE_EQ(response.stages(0).last_ms(), 1.5);
  EXPECT_DOUBLE_EQ(response.stages(0).median_ms(), 1.25);
  EXPECT_DOUBLE_EQ(response.stages(0).p95_ms(), 2.75);
  EXPECT_EQ(response.stages(1).stage(), "total");
  EXPECT_DOUBLE_EQ(response.stages(1).p95_ms(), 3.0);
  ASSERT_EQ(response.detectors_size(), 1);
  EXPECT_EQ(response.detectors(0), "depth_stats");
  EXPECT_GE(response.uptime_s(), 0.0);
  EXPECT_LT(response.uptime_s(), 60.0);
}

TEST(GetStatus, MapsEverySourceState) {
  const std::pair<SourceState, v1::GetStatusResponse::SourceState> cases[] = {
      {SourceState::kStreaming, v1::GetStatusResponse::STREAMING},
      {SourceState::kEnded, v1::GetStatusResponse::ENDED},
      {SourceState::kFailed, v1::GetStatusResponse::FAILED},
      {SourceState::kStopped, v1::GetStatusResponse::STOPPED},
      {SourceState::kReconnecting, v1::GetStatusResponse::RECONNECTING}};
  SourceState current = SourceState::kStreaming;
  TestServer srv(4, [&] { return knownStatus(current); });
  for (const auto& [state, expected] : cases) {
    current = state;
    v1::GetStatusResponse response;
    auto context = clientContext();
    ASSERT_TRUE(srv.stub().GetStatus(context.get(), {}, &response).ok());
    EXPECT_EQ(response.source_state(), expected) << toString(state);
  }
}

TEST(GetStatus, CountersFollowThePipelineBetweenCalls) {
  std::atomic<std::uint64_t> received{0};
  TestServer srv(4, [&] {
    PipelineStatus s;
    s.frames_received = received.load();
    return s;
  });
  for (std::uint64_t n : {0u, 5u, 17u}) {
    received = n;
    v1::GetStatusResponse response;
    auto context = clientContext();
    ASSERT_TRUE(srv.stub().GetStatus(context.get(), {}, &response).ok());
    EXPECT_EQ(response.frames_received(), n);
  }
}

TEST(GetStatus, EmptyCacheAnswersWithZeroRange) {
  TestServer srv(5);  // default pipeline_status: no pipeline
  v1::GetStatusResponse response;
  auto context = clientContext();
  const grpc::Status status = srv.stub().GetStatus(context.get(), {}, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.cache().frames(), 0u);
  EXPECT_EQ(response.cache().capacity(), 5u);
  EXPECT_EQ(response.cache().oldest_ns(), 0);
  EXPECT_EQ(response.cache().newest_ns(), 0);
  EXPECT_EQ(response.frames_received(), 0u);
  EXPECT_EQ(response.stages_size(), 0);
}

TEST(GetStatus, UptimeGrows) {
  TestServer srv(4);
  auto uptime = [&] {
    v1::GetStatusResponse response;
    auto context = clientContext();
    EXPECT_TRUE(srv.stub().GetStatus(context.get(), {}, &response).ok());
    return response.uptime_s();
  };
  const double first = uptime();
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  EXPECT_GE(uptime() - first, 0.025);
}

/// A live source whose sensor state the test sets; delivers no frame until stopped.
class FakeLiveSource final : public FrameSource {
 public:
  explicit FakeLiveSource(std::atomic<bool>& connected) : connected_(connected) {}
  std::string describe() const override { return "freenect:0"; }
  SourceEvent next(std::stop_token stop) override {
    while (!stop.stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    return EndOfStream{};
  }
  SourceHealth health() const override {
    return {.live = true, .connected = connected_.load(), .reconnects = 3, .dropped_frames = 11};
  }

 private:
  std::atomic<bool>& connected_;
};

v1::GetStatusResponse statusOf(TestServer& srv) {
  v1::GetStatusResponse response;
  auto context = clientContext();
  EXPECT_TRUE(srv.stub().GetStatus(context.get(), {}, &response).ok());
  return response;
}

TEST(GetStatus, ReportsALostLiveSensorAsReconnecting) {
  std::atomic<bool> connected{true};
  FrameCache cache(4);
  SummaryHub hub;
  Pipeline pipeline(std::make_unique<FakeLiveSource>(connected),
                    makeDetectorChain(DetectorConfig{}), cache, hub);
  pipeline.start();
  TestServer srv(4, [&] { return pipeline.status(); });

  v1::GetStatusResponse response = statusOf(srv);
  EXPECT_EQ(response.source_state(), v1::GetStatusResponse::STREAMING);
  EXPECT_TRUE(response.source_live());
  EXPECT_TRUE(response.source_connected());
  EXPECT_EQ(response.source_reconnects(), 3u);
  EXPECT_EQ(response.source_dropped_frames(), 11u);

  connected = false;
  response = statusOf(srv);
  EXPECT_EQ(response.source_state(), v1::GetStatusResponse::RECONNECTING);
  EXPECT_FALSE(response.source_connected());

  connected = true;
  EXPECT_EQ(statusOf(srv).source_state(), v1::GetStatusResponse::STREAMING);
  pipeline.stop();
  // Stopped wins over the sensor state.
  connected = false;
  EXPECT_EQ(statusOf(srv).source_state(), v1::GetStatusResponse::STOPPED);
}

TEST(GetStatus, RecordingsAreNotLiveAndAlwaysConnected) {
  TestServer srv(4);  // default PipelineStatus: default SourceHealth
  const v1::GetStatusResponse response = statusOf(srv);
  EXPECT_FALSE(response.source_live());
  EXPECT_TRUE(response.source_connected());
  EXPECT_EQ(response.source_reconnects(), 0u);
  EXPECT_EQ(response.source_dropped_frames(), 0u);
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
