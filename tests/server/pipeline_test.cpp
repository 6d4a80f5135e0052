// Pipeline with a scripted fake FrameSource and a deliberately slow detector stage; and
// LatencyTracker statistics on known samples.

#include "shapesense/server/pipeline.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <future>
#include <mutex>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "shapesense/core/pipeline/stages.h"
#include "shapesense/server/latency_tracker.h"
#include "source_wait.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr TimestampNs kT0 = 1'700'000'000'000'000'000LL;
constexpr TimestampNs kStep = 33'333'333;

Frame smallFrame(TimestampNs t, std::uint64_t sequence) {
  Frame f;
  f.timestamp_ns = t;
  f.sequence = sequence;
  f.depth = cv::Mat(4, 4, CV_16UC1, cv::Scalar(1000 + static_cast<double>(sequence)));
  return f;
}

// Plays a script of events, then either ends, blocks until stopped, or throws.
class FakeSource : public FrameSource {
 public:
  using Step = std::function<SourceEvent()>;
  enum class After { kEnd, kBlockUntilStopped };

  FakeSource(std::vector<Step> script, After after = After::kEnd)
      : script_(std::move(script)), after_(after) {}

  static Step frame(TimestampNs t, std::uint64_t sequence) {
    return [=] { return SourceEvent{smallFrame(t, sequence)}; };
  }
  static Step error(std::string message) {
    return [=] { return SourceEvent{SourceError{message}}; };
  }
  static Step fail(std::string message) {
    return [=]() -> SourceEvent { throw std::runtime_error(message); };
  }

  std::string describe() const override { return "fake:test"; }

  SourceEvent next(std::stop_token stop) override {
    if (position_ < script_.size()) return script_[position_++]();
    if (after_ == After::kEnd) return EndOfStream{};
    // Like a live sensor waiting for the next frame: only a stop request ends the wait.
    testing::waitUntilStopped(stop);
    return EndOfStream{};
  }

 private:
  std::vector<Step> script_;
  After after_;
  std::size_t position_ = 0;
};

class SlowStage : public DetectorStage {
 public:
  explicit SlowStage(std::chrono::milliseconds delay) : delay_(delay) {}
  std::string name() const override { return "slow"; }
  void run(const Frame&, FrameResults&) override { std::this_thread::sleep_for(delay_); }

 private:
  std::chrono::milliseconds delay_;
};

// Throws on every frame whose sequence is odd.
class FlakyStage : public DetectorStage {
 public:
  std::string name() const override { return "flaky"; }
  void run(const Frame& frame, FrameResults&) override {
    if (frame.sequence % 2 == 1) throw std::runtime_error("odd frame");
  }
};

DetectorChain slowChain(std::chrono::milliseconds delay = 3ms) {
  DetectorChain chain;
  chain.add(std::make_unique<DepthStatsStage>());
  chain.add(std::make_unique<SlowStage>(delay));
  return chain;
}

std::vector<FakeSource::Step> frames(int n, TimestampNs first = kT0) {
  std::vector<FakeSource::Step> steps;
  for (int i = 0; i < n; ++i) steps.push_back(FakeSource::frame(first + i * kStep, i));
  return steps;
}

TEST(Pipeline, FastSourceSlowDetectorsSkipsButCachesEverything) {
  constexpr int kN = 60;
  FrameCache cache(128);
  SummaryHub hub;
  auto subscription = hub.subscribe(1000);
  Pipeline pipeline(std::make_unique<FakeSource>(frames(kN)), slowChain(), cache, hub);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(10s));
  const PipelineStatus status = pipeline.status();
  EXPECT_EQ(status.source, "fake:test");
  EXPECT_EQ(status.state, SourceState::kEnded);
  EXPECT_EQ(status.frames_received, static_cast<std::uint64_t>(kN));
  EXPECT_EQ(status.frames_processed + status.frames_skipped, static_cast<std::uint64_t>(kN));
  EXPECT_GT(status.frames_skipped, 0u);
  EXPECT_GT(status.frames_processed, 0u);
  EXPECT_EQ(status.source_errors, 0u);
  EXPECT_THAT(status.detectors, ElementsAre("depth_stats", "slow"));

  // The cache holds every frame; exactly the processed ones carry results.
  const CachedRange range = cache.range();
  EXPECT_EQ(range.frames, static_cast<std::size_t>(kN));
  EXPECT_EQ(range.oldest_ns, kT0);
  EXPECT_EQ(range.newest_ns, kT0 + (kN - 1) * kStep);
  std::uint64_t with_results = 0;
  for (const auto& entry : cache.list()) {
    if (entry.results) {
      ++with_results;
      EXPECT_TRUE(entry.results->depth_stats.has_value());
      EXPECT_EQ(entry.results->timings_ms.count("slow"), 1u);
    }
  }
  EXPECT_EQ(with_results, status.frames_processed);
  // The newest frame is never skipped: the detectors always get to it.
  EXPECT_NE(std::get<CachedFrame>(cache.at(0)).results, nullptr);

  // Latency per stage plus "total", one run per processed frame.
  std::vector<std::string> stage_names;
  for (const auto& stage : status.stages) {
    stage_names.push_back(stage.stage);
    EXPECT_EQ(stage.runs, status.frames_processed) << stage.stage;
  }
  EXPECT_THAT(stage_names, ::testing::UnorderedElementsAre("depth_stats", "slow", "total"));
  for (const auto& stage : status.stages) {
    if (stage.stage == "slow" || stage.stage == "total") {
      EXPECT_GE(stage.median_ms, 2.5) << stage.stage;
    }
  }

  // Every processed frame went to Watch subscribers, in order.
  std::uint64_t published = 0;
  std::uint64_t last_sequence = 0;
  while (auto item = subscription->pop(0ms)) {
    EXPECT_EQ(item->dropped_before, 0u);
    if (published > 0) {
      EXPECT_GT(item->frame.frame->sequence, last_sequence);
    }
    last_sequence = item->frame.frame->sequence;
    ASSERT_NE(item->frame.results, nullptr);
    ++published;
  }
  EXPECT_EQ(published, status.frames_processed);
  EXPECT_EQ(last_sequence, static_cast<std::uint64_t>(kN - 1));
}

TEST(Pipeline, SourceErrorsAreCountedAndTheStreamGoesOn) {
  FrameCache cache(16);
  SummaryHub hub;
  std::vector<FakeSource::Step> script = {
      FakeSource::frame(kT0, 0), FakeSource::error("/rec/depth/1.png: missing depth image"),
      FakeSource::frame(kT0 + kStep, 1), FakeSource::error("/rec/depth/3.png: truncated"),
      FakeSource::frame(kT0 + 3 * kStep, 2)};
  Pipeline pipeline(std::make_unique<FakeSource>(script), slowChain(0ms), cache, hub);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(5s));
  const PipelineStatus status = pipeline.status();
  EXPECT_EQ(status.source_errors, 2u);
  EXPECT_EQ(status.frames_received, 3u);
  EXPECT_EQ(status.frames_processed + status.frames_skipped, 3u);
  EXPECT_EQ(status.last_error, "/rec/depth/3.png: truncated");
  EXPECT_EQ(status.state, SourceState::kEnded);
  EXPECT_EQ(cache.range().frames, 3u);
}

TEST(Pipeline, OutOfOrderFrameIsDroppedAndCounted) {
  FrameCache cache(16);
  SummaryHub hub;
  std::vector<FakeSource::Step> script = {FakeSource::frame(kT0 + kStep, 0),
                                          FakeSource::frame(kT0, 1),  // older than the newest
                                          FakeSource::frame(kT0 + 2 * kStep, 2)};
  Pipeline pipeline(std::make_unique<FakeSource>(script), slowChain(0ms), cache, hub);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(5s));
  const PipelineStatus status = pipeline.status();
  EXPECT_EQ(status.frames_received, 2u);
  EXPECT_EQ(status.frames_out_of_order, 1u);
  EXPECT_EQ(status.source_errors, 0u);  // the source delivered it; the cache refused it
  EXPECT_THAT(status.last_error, HasSubstr("is not after the newest cached frame"));
  EXPECT_EQ(cache.range().frames, 2u);
  EXPECT_FALSE(cache.bySequence(1).has_value());
}

TEST(Pipeline, EndOfStreamLeavesTheCacheServing) {
  FrameCache cache(16);
  SummaryHub hub;
  Pipeline pipeline(std::make_unique<FakeSource>(frames(5)), slowChain(0ms), cache, hub);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(5s));
  EXPECT_EQ(pipeline.status().state, SourceState::kEnded);
  EXPECT_TRUE(pipeline.status().last_error.empty());
  // Still answers after the end, and after stop().
  auto found = cache.at(kT0 + 2 * kStep + 5);
  ASSERT_TRUE(std::holds_alternative<CachedFrame>(found));
  EXPECT_EQ(std::get<CachedFrame>(found).frame->sequence, 2u);
  pipeline.stop();
  EXPECT_EQ(pipeline.status().state, SourceState::kEnded);
  EXPECT_EQ(cache.range().frames, 5u);
  ASSERT_TRUE(std::holds_alternative<CachedFrame>(cache.at(0)));
  EXPECT_EQ(std::get<CachedFrame>(cache.at(0)).frame->sequence, 4u);
}

TEST(Pipeline, AStageThatThrowsFailsOnlyThatFrameAndStage) {
  FrameCache cache(16);
  SummaryHub hub;
  DetectorChain chain;
  chain.add(std::make_unique<FlakyStage>());
  chain.add(std::make_unique<DepthStatsStage>());
  Pipeline pipeline(std::make_unique<FakeSource>(frames(4)), std::move(chain), cache, hub, nullptr);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(5s));
  const PipelineStatus status = pipeline.status();
  EXPECT_EQ(status.frames_processed + status.frames_skipped, 4u);
  for (int i = 0; i < 4; ++i) {
    const auto found = cache.at(kT0 + i * kStep);
    ASSERT_TRUE(std::holds_alternative<CachedFrame>(found));
    const auto& results = std::get<CachedFrame>(found).results;
    if (!results) continue;  // skipped
    // The stage after the failing one ran on every processed frame.
    EXPECT_TRUE(results->depth_stats.has_value());
    if (i % 2 == 1) {
      ASSERT_EQ(results->stage_errors.count("flaky"), 1u) << "frame " << i;
      EXPECT_EQ(results->stage_errors.at("flaky"), "odd frame");
    } else {
      EXPECT_TRUE(results->stage_errors.empty()) << "frame " << i;
    }
  }
  EXPECT_EQ(status.state, SourceState::kEnded);
}

TEST(Pipeline, ThrowingSourceFailsWithItsMessage) {
  FrameCache cache(16);
  SummaryHub hub;
  std::vector<FakeSource::Step> script = {FakeSource::frame(kT0, 0),
                                          FakeSource::fail("sensor unplugged (usb 1-2)")};
  Pipeline pipeline(std::make_unique<FakeSource>(script), slowChain(0ms), cache, hub);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(5s));
  const PipelineStatus status = pipeline.status();
  EXPECT_EQ(status.state, SourceState::kFailed);
  EXPECT_THAT(status.last_error, HasSubstr("sensor unplugged (usb 1-2)"));
  EXPECT_EQ(status.frames_received, 1u);
  EXPECT_EQ(cache.range().frames, 1u);
  pipeline.stop();
  EXPECT_EQ(pipeline.status().state, SourceState::kFailed);
}

TEST(Pipeline, StopIsPromptWhileTheSourceBlocks) {
  FrameCache cache(16);
  SummaryHub hub;
  Pipeline pipeline(std::make_unique<FakeSource>(frames(2), FakeSource::After::kBlockUntilStopped),
                    slowChain(0ms), cache, hub);
  pipeline.start();
  auto received = [&] { return pipeline.status().frames_received; };
  const auto until = std::chrono::steady_clock::now() + 5s;
  while (received() < 2 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(1ms);
  ASSERT_EQ(received(), 2u);
  EXPECT_FALSE(pipeline.waitUntilDrained(50ms));  // the source is still "live"
  EXPECT_EQ(pipeline.status().state, SourceState::kStreaming);

  auto done = std::async(std::launch::async, [&] { pipeline.stop(); });
  ASSERT_EQ(done.wait_for(2s), std::future_status::ready) << "stop() did not return";
  EXPECT_EQ(pipeline.status().state, SourceState::kStopped);
  EXPECT_EQ(cache.range().frames, 2u);
  pipeline.stop();  // a second stop is harmless
}

TEST(Pipeline, DestructorStopsARunningPipeline) {
  FrameCache cache(16);
  SummaryHub hub;
  auto done = std::async(std::launch::async, [&] {
    Pipeline pipeline(
        std::make_unique<FakeSource>(frames(1), FakeSource::After::kBlockUntilStopped),
        slowChain(0ms), cache, hub);
    pipeline.start();
    std::this_thread::sleep_for(20ms);
  });
  ASSERT_EQ(done.wait_for(2s), std::future_status::ready) << "~Pipeline did not return";
}

TEST(Pipeline, StatusBeforeStart) {
  FrameCache cache(4);
  SummaryHub hub;
  Pipeline pipeline(std::make_unique<FakeSource>(frames(1)), slowChain(0ms), cache, hub);
  const PipelineStatus status = pipeline.status();
  EXPECT_EQ(status.state, SourceState::kStreaming);
  EXPECT_EQ(status.frames_received, 0u);
  EXPECT_TRUE(status.stages.empty());
  EXPECT_THAT(status.detectors, ElementsAre("depth_stats", "slow"));
}

TEST(SourceStateNames, AreDistinct) {
  EXPECT_STREQ(toString(SourceState::kStreaming), "streaming");
  EXPECT_STREQ(toString(SourceState::kEnded), "ended");
  EXPECT_STREQ(toString(SourceState::kFailed), "failed");
  EXPECT_STREQ(toString(SourceState::kStopped), "stopped");
}

// ---------------------------------------------------------------------------------------------
// LatencyTracker

TEST(LatencyTracker, MedianAndP95OfKnownSamples) {
  LatencyTracker tracker;
  std::vector<double> samples;
  for (int i = 1; i <= 101; ++i) samples.push_back(i);
  std::shuffle(samples.begin(), samples.end(), std::mt19937(7));
  for (double ms : samples) tracker.record("stage", ms);
  const auto summaries = tracker.summaries();
  ASSERT_EQ(summaries.size(), 1u);
  EXPECT_EQ(summaries[0].stage, "stage");
  EXPECT_EQ(summaries[0].runs, 101u);
  EXPECT_DOUBLE_EQ(summaries[0].last_ms, samples.back());
  EXPECT_DOUBLE_EQ(summaries[0].median_ms, 51.0);
  EXPECT_DOUBLE_EQ(summaries[0].p95_ms, 96.0);
}

TEST(LatencyTracker, SingleSampleAndSkewedSamples) {
  LatencyTracker tracker;
  tracker.record("one", 4.5);
  // 19 fast runs and one slow one: the median ignores it, the p95 (nearest rank 19 of 20) too.
  for (int i = 0; i < 19; ++i) tracker.record("skewed", 1.0);
  tracker.record("skewed", 100.0);
  // 18 fast and two slow: now the 95th percentile is slow.
  for (int i = 0; i < 18; ++i) tracker.record("tail", 1.0);
  tracker.record("tail", 50.0);
  tracker.record("tail", 60.0);
  const auto s = tracker.summaries();
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].stage, "one");
  EXPECT_DOUBLE_EQ(s[0].median_ms, 4.5);
  EXPECT_DOUBLE_EQ(s[0].p95_ms, 4.5);
  EXPECT_EQ(s[1].stage, "skewed");
  EXPECT_DOUBLE_EQ(s[1].median_ms, 1.0);
  EXPECT_DOUBLE_EQ(s[1].p95_ms, 1.0);
  EXPECT_DOUBLE_EQ(s[1].last_ms, 100.0);
  EXPECT_EQ(s[2].stage, "tail");
  EXPECT_DOUBLE_EQ(s[2].median_ms, 1.0);
  EXPECT_GE(s[2].p95_ms, 50.0);
}

TEST(LatencyTracker, WindowForgetsOldSamples) {
  LatencyTracker tracker;
  for (int i = 0; i < 300; ++i) tracker.record("s", 1000.0);
  for (std::size_t i = 0; i < LatencyTracker::kWindow; ++i) tracker.record("s", 2.0);
  auto s = tracker.summaries();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].runs, 300u + LatencyTracker::kWindow);
  EXPECT_DOUBLE_EQ(s[0].median_ms, 2.0);
  EXPECT_DOUBLE_EQ(s[0].p95_ms, 2.0);
  // One more slow sample is 1 of 256: not the p95.
  tracker.record("s", 1000.0);
  s = tracker.summaries();
  EXPECT_DOUBLE_EQ(s[0].p95_ms, 2.0);
  EXPECT_DOUBLE_EQ(s[0].last_ms, 1000.0);
}

TEST(LatencyTracker, StagesInOrderOfFirstAppearance) {
  LatencyTracker tracker;
  tracker.record("zeta", 1);
  tracker.record("alpha", 2);
  tracker.record("zeta", 3);
  tracker.record("mid", 4);
  std::vector<std::string> names;
  for (const auto& s : tracker.summaries()) names.push_back(s.stage);
  EXPECT_THAT(names, ElementsAre("zeta", "alpha", "mid"));
  EXPECT_TRUE(LatencyTracker().summaries().empty());
}

}  // namespace
}  // namespace shapesense
