// The daemon's frame path over a faulty sensor (FaultInjectingSource): errors, a disconnection
// and return, stamps that jump back and repeat. The cache stays in capture-time order, "the frame
// at T" keeps its meaning, nothing cached is lost while the sensor is away, and GetStatus reports
// what happened. Also: a run of refused frames is logged once, not once per frame.

#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <thread>

#include "server_fixture.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/driver/fault_injecting_source.h"
#include "shapesense/server/pipeline.h"
#include "source_wait.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using testing::kFramePeriodNs;
using testing::kServerT0;

TimestampNs stampOf(int i) { return kServerT0 + i * kFramePeriodNs; }

/// `frames` frames a period apart, then waits like a sensor with nothing to send.
class SensorLikeSource final : public FrameSource {
 public:
  explicit SensorLikeSource(int frames) : frames_(frames) {}
  std::string describe() const override { return "sensor"; }
  SourceEvent next(std::stop_token stop) override {
    if (sent_ < frames_) {
      Frame frame = testing::makeTestFrame(stampOf(sent_), static_cast<std::uint64_t>(sent_));
      ++sent_;
      return frame;
    }
    testing::waitUntilStopped(stop);
    return EndOfStream{};
  }

 private:
  int frames_;
  int sent_ = 0;
};

DetectorChain depthStatsChain() {
  DetectorChain chain;
  chain.add(std::make_unique<DepthStatsStage>());
  return chain;
}

/// Polls `done` for up to 10 s (the pipeline's threads move at their own pace).
template <typename Predicate>
bool eventually(Predicate done) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

v1::GetStatusResponse getStatus(testing::TestServer& server) {
  v1::GetStatusResponse status;
  const grpc::Status rpc = server.stub().GetStatus(testing::clientContext().get(), {}, &status);
  EXPECT_TRUE(rpc.ok()) << rpc.error_message();
  return status;
}

/// The sequence number of GetFrame(T).
std::uint64_t sequenceAt(testing::TestServer& server, TimestampNs t) {
  v1::GetFrameRequest request;
  request.set_at_ns(t);
  request.set_skip_depth(true);
  request.set_skip_rgb(true);
  v1::GetFrameResponse response;
  const grpc::Status rpc =
      server.stub().GetFrame(testing::clientContext().get(), request, &response);
  EXPECT_TRUE(rpc.ok()) << rpc.error_message();
  return response.info().sequence();
}

TEST(Faults, CacheOrderLookupsAndStatusSurviveAFaultySensor) {
  // Frames 0-4, the sensor is lost until resumed, frames 5-6, frame 7 repeating frame 6's
  // stamp, frame 8 stamped three periods before that (at frame 3's time), frames 9-10, three
  // errors, frame 11.
  auto faulty = std::make_unique<FaultInjectingSource>(std::make_unique<SensorLikeSource>(12),
                                                       FaultPlan()
                                                           .pass(5)
                                                           .disconnect(kUntilResumed)
                                                           .pass(2)
                                                           .stampRepeat()
                                                           .stampBack(3 * kFramePeriodNs)
                                                           .pass(2)
                                                           .error(3));
  FaultInjectingSource& source = *faulty;
  Pipeline* running = nullptr;
  testing::TestServer server(64, [&running] { return running->status(); });
  // Declared after the server: stopped before the cache it fills goes away.
  auto pipeline = std::make_unique<Pipeline>(std::move(faulty), depthStatsChain(), server.cache(),
                                             server.hub());
  running = pipeline.get();
  pipeline->start();

  // While the sensor is away: reconnecting, the five frames still served.
  ASSERT_TRUE(eventually([&] { return source.blocked(); }));
  v1::GetStatusResponse away = getStatus(server);
  EXPECT_EQ(away.source_state(), v1::GetStatusResponse::RECONNECTING);
  EXPECT_TRUE(away.source_live());
  EXPECT_FALSE(away.source_connected());
  EXPECT_EQ(away.source_disconnects(), 1u);
  EXPECT_EQ(away.source_reconnects(), 0u);
  EXPECT_EQ(away.frames_received(), 5u);
  EXPECT_EQ(away.source_errors(), 1u);
  EXPECT_THAT(away.source_message(), HasSubstr("sensor lost"));
  EXPECT_EQ(away.cache().frames(), 5u);
  EXPECT_EQ(sequenceAt(server, stampOf(2) + 1), 2u);
  EXPECT_EQ(sequenceAt(server, 0), 4u);

  source.resume();
  ASSERT_TRUE(eventually([&] { return pipeline->status().frames_received == 10; }))
      << pipeline->status().frames_received;
  ASSERT_TRUE(eventually([&] { return pipeline->status().source_errors == 4; }));
  const v1::GetStatusResponse back = getStatus(server);
  EXPECT_EQ(back.source_state(), v1::GetStatusResponse::STREAMING);
  EXPECT_TRUE(back.source_connected());
  EXPECT_EQ(back.source_disconnects(), 1u);
  EXPECT_EQ(back.source_reconnects(), 1u);
  EXPECT_EQ(back.frames_out_of_order(), 2u);
  EXPECT_EQ(back.frames_received(), 10u);
  EXPECT_EQ(back.source_errors(), 4u);  // the loss and three errors

  // Nothing cached was lost or replaced, and the order holds.
  const std::vector<CachedFrame> cached = server.cache().list();
  std::vector<std::uint64_t> sequences;
  for (const auto& entry : cached) sequences.push_back(entry.frame->sequence);
  EXPECT_THAT(sequences, ::testing::ElementsAre(0, 1, 2, 3, 4, 5, 6, 9, 10, 11));
  for (std::size_t i = 1; i < cached.size(); ++i) {
    EXPECT_GT(cached[i].frame->timestamp_ns, cached[i - 1].frame->timestamp_ns);
  }
  // At frame 6's and frame 3's times it is frames 6 and 3, not the frames stamped onto them;
  // where frame 7 would have been, the latest frame before it.
  EXPECT_EQ(sequenceAt(server, stampOf(6)), 6u);
  EXPECT_EQ(sequenceAt(server, stampOf(3)), 3u);
  EXPECT_EQ(sequenceAt(server, stampOf(7)), 6u);
  EXPECT_EQ(sequenceAt(server, stampOf(9)), 9u);
  pipeline->stop();
}

TEST(Faults, ARunOfRefusedFramesIsLoggedOnceWhenItStartsAndOnceWhenItEnds) {
  auto sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(1024);
  spdlog::default_logger()->sinks().push_back(sink);
  {
    // A clock that jumps back ten seconds and stays behind for 49 frames.
    FaultPlan plan;
    plan.pass(1).stampBack(10'000'000'000);
    for (int i = 0; i < 48; ++i) plan.stampRepeat();
    FrameCache cache(64);
    SummaryHub hub;
    Pipeline pipeline(std::make_unique<FaultInjectingSource>(std::make_unique<SensorLikeSource>(52),
                                                             std::move(plan)),
                      depthStatsChain(), cache, hub);
    pipeline.start();
    ASSERT_TRUE(eventually([&] { return pipeline.status().frames_received == 3; }));
    EXPECT_EQ(pipeline.status().frames_out_of_order, 49u);
    pipeline.stop();
  }
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::remove(sinks.begin(), sinks.end(), sink), sinks.end());
  int refused = 0, resumed = 0;
  for (const auto& line : sink->last_formatted()) {
    refused += line.find("is not after the newest cached frame") != std::string::npos;
    resumed += line.find("49 frame(s) were dropped out of order") != std::string::npos;
  }
  EXPECT_EQ(refused, 1);
  EXPECT_EQ(resumed, 1);
}

}  // namespace
}  // namespace shapesense
