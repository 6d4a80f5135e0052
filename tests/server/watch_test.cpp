// Watch through a real in-process gRPC server: summaries published to the hub reach the client,
// a slow reader is told what it lost, and the stream ends when the server shuts down.

#include <chrono>
#include <future>
#include <vector>

#include <gtest/gtest.h>

#include "server_fixture.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/pipeline/stages.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using testing::clientContext;
using testing::kFramePeriodNs;
using testing::kServerT0;
using testing::ServerTest;
using testing::waitFor;

class WatchTest : public ServerTest {
 protected:
  std::unique_ptr<grpc::ClientReader<v1::FrameSummary>> watch(grpc::ClientContext* context,
                                                              std::uint32_t max_pending = 0) {
    v1::WatchRequest request;
    request.set_max_pending(max_pending);
    return srv.stub().Watch(context, request);
  }

  // Adds a frame to the cache with results and publishes it, as the pipeline does.
  CachedFrame publishNext(bool with_results = true) {
    const TimestampNs t = kServerT0 + static_cast<TimestampNs>(srv.added().size()) * kFramePeriodNs;
    auto frame = srv.add(t, true, with_results);
    auto entry = srv.cache().bySequence(frame->sequence);
    EXPECT_TRUE(entry.has_value());
    srv.hub().publish(*entry);
    return *entry;
  }
};

TEST_F(WatchTest, ReceivesEverySummaryPublished) {
  auto context = clientContext(10s);
  auto reader = watch(context.get());
  ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 1; })) << "Watch never subscribed";
  std::vector<CachedFrame> published;
  for (int i = 0; i < 3; ++i) published.push_back(publishNext());
  for (int i = 0; i < 3; ++i) {
    v1::FrameSummary summary;
    ASSERT_TRUE(reader->Read(&summary)) << "summary " << i;
    const Frame& frame = *published[i].frame;
    EXPECT_EQ(summary.info().sequence(), frame.sequence);
    EXPECT_EQ(summary.info().timestamp_ns(), frame.timestamp_ns);
    EXPECT_EQ(summary.info().width(), 32u);
    EXPECT_TRUE(summary.info().processed());
    EXPECT_TRUE(summary.info().has_rgb());
    EXPECT_EQ(summary.dropped_before(), 0u);
    ASSERT_TRUE(summary.has_depth_stats());
    const DepthStatistics stats = computeDepthStatistics(frame.depth);
    EXPECT_DOUBLE_EQ(summary.depth_stats().median_m(), stats.median_m);
    EXPECT_DOUBLE_EQ(summary.depth_stats().valid_fraction(), stats.valid_fraction);
    ASSERT_EQ(summary.timings_size(), 1);
    EXPECT_EQ(summary.timings(0).stage(), "depth_stats");
    EXPECT_DOUBLE_EQ(summary.timings(0).ms(), 0.25 + static_cast<double>(frame.sequence));
  }
  context->TryCancel();
  v1::FrameSummary extra;
  while (reader->Read(&extra)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // The handler notices the cancel and unsubscribes.
  EXPECT_TRUE(waitFor([&] { return srv.hub().subscribers() == 0; }));
}

TEST_F(WatchTest, UnprocessedFrameHasNoStatistics) {
  auto context = clientContext(10s);
  auto reader = watch(context.get());
  ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 1; }));
  publishNext(/*with_results=*/false);
  v1::FrameSummary summary;
  ASSERT_TRUE(reader->Read(&summary));
  EXPECT_FALSE(summary.info().processed());
  EXPECT_FALSE(summary.has_depth_stats());
  EXPECT_EQ(summary.timings_size(), 0);
  context->TryCancel();
}

TEST_F(WatchTest, SlowReaderIsToldHowManyItLost) {
  auto context = clientContext(20s);
  auto reader = watch(context.get(), /*max_pending=*/2);
  ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 1; }));
  // Publish far more than the stream's flow-control window holds while the client reads
  // nothing: the subscriber's queue must overflow.
  constexpr std::uint64_t kPublished = 20000;
  auto depth = cv::Mat(1, 1, CV_16UC1, cv::Scalar(1000));
  for (std::uint64_t i = 0; i < kPublished; ++i) {
    auto frame = std::make_shared<Frame>();
    frame->sequence = i;
    frame->timestamp_ns = kServerT0 + static_cast<TimestampNs>(i);
    frame->depth = depth;
    srv.hub().publish(CachedFrame{frame, std::make_shared<FrameResults>()});
  }
  // Every published summary is either received or counted in the next one's dropped_before;
  // the last one is always received.
  std::uint64_t accounted = 0;
  std::uint64_t dropped = 0;
  std::uint64_t received = 0;
  std::int64_t last_sequence = -1;
  v1::FrameSummary summary;
  while (reader->Read(&summary)) {
    ++received;
    accounted += 1 + summary.dropped_before();
    dropped += summary.dropped_before();
    EXPECT_GT(static_cast<std::int64_t>(summary.info().sequence()), last_sequence);
    // What was lost is exactly the gap in sequence numbers.
    EXPECT_EQ(summary.info().sequence(),
              static_cast<std::uint64_t>(last_sequence + 1) + summary.dropped_before());
    last_sequence = static_cast<std::int64_t>(summary.info().sequence());
    if (summary.info().sequence() == kPublished - 1) break;
  }
  EXPECT_EQ(last_sequence, static_cast<std::int64_t>(kPublished - 1));
  EXPECT_EQ(accounted, kPublished);
  EXPECT_GT(dropped, 0u);
  EXPECT_LT(received, kPublished);
  context->TryCancel();
}

TEST_F(WatchTest, MaxPendingLimit) {
  {
    auto context = clientContext(5s);
    auto reader = watch(context.get(), 1025);
    v1::FrameSummary summary;
    EXPECT_FALSE(reader->Read(&summary));
    const grpc::Status status = reader->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_FALSE(status.error_message().empty());
  }
  {
    auto context = clientContext(5s);
    auto reader = watch(context.get(), 0xFFFFFFFFu);
    v1::FrameSummary summary;
    EXPECT_FALSE(reader->Read(&summary));
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  }
  {
    auto context = clientContext(5s);
    auto reader = watch(context.get(), 1024);  // the largest allowed
    ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 1; }));
    publishNext();
    v1::FrameSummary summary;
    ASSERT_TRUE(reader->Read(&summary));
    EXPECT_EQ(summary.info().sequence(), 0u);
    context->TryCancel();
  }
}

TEST_F(WatchTest, TwoWatchersBothGetEverything) {
  auto c1 = clientContext(10s);
  auto c2 = clientContext(10s);
  auto r1 = watch(c1.get());
  auto r2 = watch(c2.get());
  ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 2; }));
  for (int i = 0; i < 4; ++i) publishNext();
  for (auto* reader : {r1.get(), r2.get()}) {
    for (std::uint64_t i = 0; i < 4; ++i) {
      v1::FrameSummary summary;
      ASSERT_TRUE(reader->Read(&summary));
      EXPECT_EQ(summary.info().sequence(), i);
      EXPECT_EQ(summary.dropped_before(), 0u);
    }
  }
  c1->TryCancel();
  c2->TryCancel();
}

TEST_F(WatchTest, ServerShutdownEndsAnOpenStream) {
  auto context = clientContext(10s);
  auto reader = watch(context.get());
  ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 1; }));
  publishNext();
  v1::FrameSummary summary;
  ASSERT_TRUE(reader->Read(&summary));

  const auto start = std::chrono::steady_clock::now();
  auto shutdown = std::async(std::launch::async, [&] { srv.server().shutdown(); });
  ASSERT_EQ(shutdown.wait_for(5s), std::future_status::ready) << "shutdown() hung";
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);

  // The client sees the end of the stream, well before its own deadline.
  auto ended = std::async(std::launch::async, [&] {
    v1::FrameSummary more;
    while (reader->Read(&more)) {
    }
    return reader->Finish();
  });
  ASSERT_EQ(ended.wait_for(3s), std::future_status::ready) << "stream still open after shutdown";
  const grpc::Status status = ended.get();
  EXPECT_NE(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << status.error_message();
}

}  // namespace
}  // namespace shapesense
