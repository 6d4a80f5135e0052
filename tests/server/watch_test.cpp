// Watch through a real in-process gRPC server: summaries published to the hub reach the client,
// a slow reader is told what it lost, and the stream ends when the server shuts down.

#include <dirent.h>

#include <chrono>
#include <future>
#include <thread>
#include <vector>

#include <grpcpp/create_channel.h>

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
using testing::TestServer;
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
  auto reader = watch(context.get(), /*max_pending=*/3);
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

/// Threads of this process (client and server side both count).
std::size_t threadCount() {
  std::size_t n = 0;
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return 0;
  while (const dirent* entry = readdir(dir)) n += entry->d_name[0] != '.';
  closedir(dir);
  return n;
}

/// A frame with no image worth the name, `sequence` as given.
CachedFrame tinyFrame(std::uint64_t sequence) {
  static const cv::Mat depth(1, 1, CV_16UC1, cv::Scalar(1000));
  auto frame = std::make_shared<Frame>();
  frame->sequence = sequence;
  frame->timestamp_ns = kServerT0 + static_cast<TimestampNs>(sequence);
  frame->depth = depth;
  return CachedFrame{frame, std::make_shared<FrameResults>()};
}

TEST_F(WatchTest, StalledSubscriberIsOneBehindWhenItReadsAgain) {
  // A client that asks the transport to hold as little as it can for it (as `shapesense watch`
  // does; gRPC still lets one message through): what it reads after a stall is the summary
  // that was being written when it stalled, then the newest, which the daemon kept for it.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 1);
  auto channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(srv.port()),
                                           grpc::InsecureChannelCredentials(), args);
  auto stub = v1::ShapeSense::NewStub(channel);
  auto context = clientContext(20s);
  auto reader = stub->Watch(context.get(), v1::WatchRequest());  // default: latest wins
  ASSERT_TRUE(waitFor([&] { return srv.hub().subscribers() == 1; }));
  std::uint64_t sequence = 0;
  // The client stalls while 3000 frames are published at a pace the server can write them.
  for (; sequence < 3000; ++sequence) {
    srv.hub().publish(tinyFrame(sequence));
    if (sequence % 100 == 0) std::this_thread::sleep_for(1ms);
  }
  std::this_thread::sleep_for(50ms);
  // It reads what reached it and what waited in the daemon.
  std::uint64_t received = 0;
  std::uint64_t dropped = 0;
  v1::FrameSummary summary;
  while (reader->Read(&summary)) {
    ++received;
    dropped += summary.dropped_before();
    if (summary.info().sequence() == sequence - 1) break;
  }
  EXPECT_EQ(summary.info().sequence(), sequence - 1) << "never got the newest summary";
  EXPECT_GT(dropped, 0u);
  std::printf("stalled subscriber: %llu summaries read to reach the newest, %llu dropped\n",
              static_cast<unsigned long long>(received), static_cast<unsigned long long>(dropped));
  EXPECT_LE(received, 2u) << "the stalled client drained stale summaries";
  // Caught up, it reads as fast as frames come: each new frame arrives at most one behind.
  for (int k = 0; k < 50; ++k, ++sequence) {
    srv.hub().publish(tinyFrame(sequence));
    ASSERT_TRUE(reader->Read(&summary));
    EXPECT_GE(summary.info().sequence() + 1, sequence) << "more than one behind at frame " << k;
    while (summary.info().sequence() != sequence) ASSERT_TRUE(reader->Read(&summary));
    EXPECT_EQ(summary.dropped_before(), 0u);
  }
  context->TryCancel();
}

TEST_F(WatchTest, ManyStreamsDoNotTakeAThreadEach) {
  TestServer server(16, {}, {}, [] {
    ServerLimits limits;
    limits.max_watch_per_client = limits.max_watch_streams = 1000;
    limits.max_streams_per_connection = 1000;
    return limits;
  }());
  constexpr int kStreams = 200;
  // Let the server's and the client's first threads start before counting.
  {
    auto context = clientContext(5s);
    v1::GetStatusResponse status;
    ASSERT_TRUE(server.stub().GetStatus(context.get(), {}, &status).ok());
  }
  const std::size_t before = threadCount();
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::FrameSummary>>> readers;
  for (int i = 0; i < kStreams; ++i) {
    contexts.push_back(clientContext(30s));
    readers.push_back(server.stub().Watch(contexts.back().get(), v1::WatchRequest()));
  }
  ASSERT_TRUE(waitFor([&] { return server.hub().subscribers() == kStreams; }, 10s))
      << server.hub().subscribers() << " of " << kStreams << " subscribed";
  server.hub().publish(tinyFrame(0));
  for (auto& reader : readers) {
    v1::FrameSummary summary;
    ASSERT_TRUE(reader->Read(&summary));
  }
  const std::size_t during = threadCount();
  std::printf("threads: %zu before, %zu with %d Watch streams\n", before, during, kStreams);
  EXPECT_LT(during, before + 50);
  for (auto& context : contexts) context->TryCancel();
  for (auto& reader : readers) {
    v1::FrameSummary rest;
    while (reader->Read(&rest)) {
    }
    reader->Finish();
  }
  EXPECT_TRUE(waitFor([&] { return server.hub().subscribers() == 0; }));
}

TEST_F(WatchTest, StreamsPerClientAndInAllAreLimited) {
  TestServer server(16, {}, {}, [] {
    ServerLimits limits;
    limits.max_watch_per_client = 2;
    limits.max_watch_streams = 3;
    return limits;
  }());
  auto open = [&](grpc::ClientContext* context) {
    return server.stub().Watch(context, v1::WatchRequest());
  };
  auto c1 = clientContext(10s);
  auto c2 = clientContext(10s);
  auto r1 = open(c1.get());
  auto r2 = open(c2.get());
  ASSERT_TRUE(waitFor([&] { return server.hub().subscribers() == 2; }));
  {
    auto c3 = clientContext(5s);
    auto r3 = open(c3.get());
    v1::FrameSummary summary;
    EXPECT_FALSE(r3->Read(&summary));
    const grpc::Status status = r3->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_NE(status.error_message().find("--max-watch-per-client"), std::string::npos)
        << status.error_message();
  }
  // A stream that ends gives its slot back.
  c2->TryCancel();
  v1::FrameSummary rest;
  while (r2->Read(&rest)) {
  }
  r2->Finish();
  ASSERT_TRUE(waitFor([&] { return server.hub().subscribers() == 1; }));
  auto c4 = clientContext(10s);
  auto r4 = open(c4.get());
  ASSERT_TRUE(waitFor([&] { return server.hub().subscribers() == 2; }));
  server.hub().publish(tinyFrame(0));
  v1::FrameSummary summary;
  EXPECT_TRUE(r4->Read(&summary));
  c1->TryCancel();
  c4->TryCancel();
}

TEST(StreamQuota, ClientIsThePeerWithoutItsPortAndTheTotalCounts) {
  EXPECT_EQ(StreamQuota::clientOf("ipv4:10.0.0.7:41234"), "ipv4:10.0.0.7");
  EXPECT_EQ(StreamQuota::clientOf("ipv6:[::1]:5000"), "ipv6:[::1]");
  EXPECT_EQ(StreamQuota::clientOf("unix:/run/shapesense.sock"), "unix:/run/shapesense.sock");
  StreamQuota quota(/*per_client=*/2, /*total=*/3);
  std::string refusal;
  auto a1 = quota.tryAcquire("ipv4:10.0.0.7:1", refusal);
  auto a2 = quota.tryAcquire("ipv4:10.0.0.7:2", refusal);
  ASSERT_TRUE(a1 && a2);
  EXPECT_FALSE(quota.tryAcquire("ipv4:10.0.0.7:3", refusal));
  EXPECT_NE(refusal.find("--max-watch-per-client"), std::string::npos);
  auto b1 = quota.tryAcquire("ipv4:10.0.0.8:1", refusal);
  ASSERT_TRUE(b1);
  EXPECT_FALSE(quota.tryAcquire("ipv4:10.0.0.9:1", refusal));
  EXPECT_NE(refusal.find("--max-watch-streams"), std::string::npos);
  a1.reset();
  EXPECT_EQ(quota.open(), 2u);
  EXPECT_TRUE(quota.tryAcquire("ipv4:10.0.0.9:1", refusal));
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
  auto r1 = watch(c1.get(), 4);
  auto r2 = watch(c2.get(), 4);
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
