// FaultInjectingSource plays its plan over the wrapped source: errors, stamps that go back or
// repeat, stalls and a disconnection that blocks until resumed, and reports them in health().

#include "shapesense/driver/fault_injecting_source.h"
#include "source_wait.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <future>
#include <thread>

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using testing::nextWithin;

constexpr TimestampNs kT0 = 1'700'000'000'000'000'000LL;
constexpr TimestampNs kStep = 33'333'333;

/// Frames kStep apart, then the end.
class CountingSource final : public FrameSource {
 public:
  explicit CountingSource(int frames) : frames_(frames) {}
  std::string describe() const override { return "counting"; }
  SourceEvent next(std::stop_token) override {
    if (sent_ == frames_) return EndOfStream{};
    Frame frame;
    frame.timestamp_ns = kT0 + sent_ * kStep;
    frame.sequence = static_cast<std::uint64_t>(sent_);
    frame.depth = cv::Mat(2, 2, CV_16UC1, cv::Scalar(1000 + sent_));
    ++sent_;
    return frame;
  }

 private:
  int frames_;
  int sent_ = 0;
};

std::unique_ptr<FaultInjectingSource> faulty(int frames, FaultPlan plan) {
  return std::make_unique<FaultInjectingSource>(std::make_unique<CountingSource>(frames),
                                                std::move(plan));
}

/// The event's frame, by value: callers pass the temporary event next() returns.
Frame frameOf(SourceEvent event) {
  EXPECT_TRUE(std::holds_alternative<Frame>(event));
  return std::get<Frame>(std::move(event));
}

TEST(FaultInjectingSource, PlaysErrorsAndStampFaultsThenPassesThrough) {
  auto source = faulty(6, FaultPlan().pass(2).error(2).stampBack(kStep * 10).stampRepeat());
  EXPECT_EQ(source->describe(), "faults(counting)");
  std::stop_source stop;
  const auto next = [&] { return source->next(stop.get_token()); };
  EXPECT_EQ(frameOf(next()).timestamp_ns, kT0);
  EXPECT_EQ(frameOf(next()).timestamp_ns, kT0 + kStep);
  for (int k = 1; k <= 2; ++k) {
    auto event = next();
    ASSERT_TRUE(std::holds_alternative<SourceError>(event));
    EXPECT_THAT(std::get<SourceError>(event).message,
                HasSubstr("injected error " + std::to_string(k) + " of 2"));
  }
  // Frame 2 stamped 10 periods before frame 1, frame 3 with frame 2's stamp again.
  const Frame back = frameOf(next());
  EXPECT_EQ(back.sequence, 2u);
  EXPECT_EQ(back.timestamp_ns, kT0 + kStep - 10 * kStep);
  const Frame repeated = frameOf(next());
  EXPECT_EQ(repeated.sequence, 3u);
  EXPECT_EQ(repeated.timestamp_ns, kT0 + kStep - 10 * kStep);
  // The plan is played: the wrapped source's own stamps again, then its end.
  EXPECT_EQ(frameOf(next()).timestamp_ns, kT0 + 4 * kStep);
  EXPECT_EQ(frameOf(next()).timestamp_ns, kT0 + 5 * kStep);
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(next()));
  // No disconnection in the plan: a recording stays a recording.
  EXPECT_FALSE(source->health().live);
}

TEST(FaultInjectingSource, DisconnectionIsReportedHeldAndEndedByResume) {
  auto source = faulty(4, FaultPlan().pass(1).disconnect(kUntilResumed));
  EXPECT_TRUE(source->health().live);
  EXPECT_TRUE(source->health().connected);
  EXPECT_TRUE(std::holds_alternative<Frame>(nextWithin(*source, 2s)));
  auto lost = nextWithin(*source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(lost));
  EXPECT_THAT(std::get<SourceError>(lost).message, HasSubstr("sensor lost"));
  EXPECT_FALSE(source->health().connected);
  EXPECT_EQ(source->health().disconnects, 1u);
  EXPECT_EQ(source->health().reconnects, 0u);

  std::stop_source stop;
  auto pending = std::async(std::launch::async, [&] { return source->next(stop.get_token()); });
  while (!source->blocked()) std::this_thread::sleep_for(1ms);
  EXPECT_FALSE(source->health().connected);
  source->resume();
  ASSERT_EQ(pending.wait_for(5s), std::future_status::ready);
  const SourceEvent back = pending.get();
  EXPECT_EQ(frameOf(back).sequence, 1u);
  EXPECT_TRUE(source->health().connected);
  EXPECT_EQ(source->health().disconnects, 1u);
  EXPECT_EQ(source->health().reconnects, 1u);
}

TEST(FaultInjectingSource, StallEndsAfterItsDurationOrOnStop) {
  auto timed = faulty(2, FaultPlan().stall(20ms));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(std::holds_alternative<Frame>(nextWithin(*timed, 5s)));
  EXPECT_GE(std::chrono::steady_clock::now() - start, 20ms);  // a lower bound: it did stall

  auto held = faulty(2, FaultPlan().stall(kUntilResumed));
  std::stop_source stop;
  auto pending = std::async(std::launch::async, [&] { return held->next(stop.get_token()); });
  while (!held->blocked()) std::this_thread::sleep_for(1ms);
  stop.request_stop();
  ASSERT_EQ(pending.wait_for(5s), std::future_status::ready);
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(pending.get()));
}

}  // namespace
}  // namespace shapesense
