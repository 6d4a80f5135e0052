// Tests of SyntheticSource: stamps, sequence, end of stream, pacing and prompt stop.

#include "shapesense/driver/synthetic_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <ctime>
#include <thread>

namespace shapesense::synthetic {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

TEST(SyntheticSource, DescribesItselfBySeed) {
  SyntheticSourceOptions options;
  options.scene.seed = 7;
  EXPECT_EQ(SyntheticSource(options).describe(), "synthetic(seed=7)");
}

TEST(SyntheticSource, StampsAndSequencesFramesAndEnds) {
  SyntheticSourceOptions options;
  options.fps = 15.0;
  options.pacing = Pacing::kAsFastAsPossible;
  options.max_frames = 3;
  options.start_ns = 1'700'000'000'000'000'000;
  SyntheticSource source(options);
  EXPECT_FALSE(source.lastTruth().has_value());
  for (std::uint64_t i = 0; i < 3; ++i) {
    SourceEvent event = source.next({});
    ASSERT_TRUE(std::holds_alternative<Frame>(event)) << i;
    const Frame& frame = std::get<Frame>(event);
    EXPECT_EQ(frame.sequence, i);
    EXPECT_EQ(frame.timestamp_ns,
              options.start_ns + static_cast<TimestampNs>(std::llround(i * 1e9 / 15.0)));
    // The truth handed out matches a fresh render of the same frame.
    ASSERT_TRUE(source.lastTruth().has_value());
    const RenderedFrame again = source.scene().render(i, frame.timestamp_ns);
    EXPECT_EQ(cv::norm(again.frame.depth, frame.depth, cv::NORM_INF), 0.0);
    EXPECT_EQ(
        cv::norm(again.truth.surface_labels, source.lastTruth()->surface_labels, cv::NORM_INF),
        0.0);
  }
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next({})));
  EXPECT_EQ(source.scene().params().frame_rate_hz, 15.0);  // the sway runs in real time
}

TEST(SyntheticSource, StartsAtTheHostClockByDefault) {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  const TimestampNs before = static_cast<TimestampNs>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
  SyntheticSourceOptions options;
  options.pacing = Pacing::kAsFastAsPossible;
  SyntheticSource source(options);
  const Frame frame = std::get<Frame>(source.next({}));
  EXPECT_GE(frame.timestamp_ns, before);
  EXPECT_LT(frame.timestamp_ns - before, 5'000'000'000);
}

TEST(SyntheticSource, PacesFramesToTheFrameRate) {
  SyntheticSourceOptions options;
  options.fps = 20.0;
  options.scene.render_colour = false;
  // Rendering alone (unpaced) sets the scale: a sanitizer build or a busy machine renders
  // several times slower, and only the pacing on top of it is under test.
  options.pacing = Pacing::kAsFastAsPossible;
  SyntheticSource unpaced(options);
  auto start = Clock::now();
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(std::holds_alternative<Frame>(unpaced.next({})));
  const double render_only = secondsSince(start);

  options.pacing = Pacing::kRecorded;
  SyntheticSource source(options);
  start = Clock::now();
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(std::holds_alternative<Frame>(source.next({})));
  // Frame 5 is due 5 / 20 s after the first; a paced source never delivers it earlier, and
  // waits no longer than that beyond its rendering (slack for scheduling).
  const double elapsed = secondsSince(start);
  EXPECT_GE(elapsed, 0.25 - 0.002);
  EXPECT_LT(elapsed, 0.25 + 2.0 * render_only + 0.5);
}

TEST(SyntheticSource, AsFastAsPossibleDoesNotSleep) {
  SyntheticSourceOptions options;
  options.fps = 0.2;  // would take 15 s if paced
  options.pacing = Pacing::kAsFastAsPossible;
  options.scene.render_colour = false;
  SyntheticSource source(options);
  const auto start = Clock::now();
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(std::holds_alternative<Frame>(source.next({})));
  EXPECT_LT(secondsSince(start), 10.0);
}

TEST(SyntheticSource, StopRequestEndsThePacingWaitPromptly) {
  SyntheticSourceOptions options;
  options.fps = 0.2;  // 5 s between frames
  options.scene.render_colour = false;
  SyntheticSource source(options);
  std::stop_source stop;
  ASSERT_TRUE(std::holds_alternative<Frame>(source.next(stop.get_token())));
  std::jthread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop.request_stop();
  });
  const auto start = Clock::now();
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
  const double elapsed = secondsSince(start);
  EXPECT_GE(elapsed, 0.09);
  EXPECT_LT(elapsed, 2.5);  // well before the 5 s the pacing would wait (rendering may be slow)
  // Already stopped: returns at once.
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

TEST(SyntheticSource, RejectsNonPositiveFps) {
  SyntheticSourceOptions options;
  options.fps = 0.0;
  EXPECT_THROW(SyntheticSource{options}, std::invalid_argument);
}

}  // namespace
}  // namespace shapesense::synthetic
