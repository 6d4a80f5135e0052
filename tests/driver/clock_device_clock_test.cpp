// DeviceClock: unwrapping the Kinect's 32-bit 60 MHz counter and mapping it to host time with
// a median-based filter that follows drift and ignores outliers.

#include "shapesense/driver/device_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>

namespace shapesense {
namespace {

constexpr TimestampNs kEpoch = 1'700'000'000'000'000'000;
constexpr double kTick = 60e6;

/// A simulated sensor: true capture times at 30 Hz on the host clock, a device counter running
/// at 60 MHz * (1 + drift), and arrival = capture + latency (+ jitter, + rare outliers).
struct SimulatedSensor {
  double drift_ppm = 0.0;
  std::uint64_t first_ticks = 0;
  double latency_ms = 8.0;
  double jitter_ms = 2.0;
  double outlier_rate = 0.0;
  double outlier_ms = 150.0;
  std::mt19937_64 rng{42};

  TimestampNs capture(int i) const { return kEpoch + static_cast<TimestampNs>(i * 1e9 / 30.0); }
  std::uint32_t ticks(int i) const {
    const double device_s = (i / 30.0) * (1.0 + drift_ppm * 1e-6);
    return static_cast<std::uint32_t>(
        (first_ticks + static_cast<std::uint64_t>(std::llround(device_s * kTick))) & 0xFFFFFFFFull);
  }
  TimestampNs arrival(int i) {
    std::uniform_real_distribution<double> jitter(0.0, jitter_ms);
    std::bernoulli_distribution outlier(outlier_rate);
    double ms = latency_ms + jitter(rng);
    if (outlier(rng)) ms += outlier_ms;
    return capture(i) + static_cast<TimestampNs>(ms * 1e6);
  }
};

TEST(DeviceClock, RejectsImpossibleParams) {
  EXPECT_THROW(DeviceClock(DeviceClockParams{.tick_hz = 0}), std::invalid_argument);
  EXPECT_THROW(DeviceClock(DeviceClockParams{.counter_bits = 65}), std::invalid_argument);
  EXPECT_THROW(DeviceClock(DeviceClockParams{.window = 0}), std::invalid_argument);
  EXPECT_THROW(DeviceClock(DeviceClockParams{.drift_blocks = 1}), std::invalid_argument);
}

TEST(DeviceClock, FirstSampleMapsToItsArrival) {
  DeviceClock clock;
  EXPECT_FALSE(clock.toHost(0).has_value());
  EXPECT_EQ(clock.map(123456, kEpoch), kEpoch);
  EXPECT_EQ(clock.lastDeviceNs(), 0);
  // 60 ticks = 1 us later on the device clock.
  EXPECT_EQ(*clock.toHost(123456 + 60), kEpoch + 1000);
}

TEST(DeviceClock, UnwrapsThe32BitCounterEvery71Seconds) {
  // 2^32 / 60 MHz = 71.58 s. Start 1 s before the wrap and run 200 s (three wraps).
  SimulatedSensor sensor{.first_ticks = (std::uint64_t{1} << 32) - 60'000'000, .jitter_ms = 0.0};
  DeviceClock clock;
  TimestampNs previous = 0;
  int wraps = 0;
  std::uint32_t previous_ticks = sensor.ticks(0);
  for (int i = 0; i < 200 * 30; ++i) {
    const std::uint32_t ticks = sensor.ticks(i);
    if (ticks < previous_ticks) ++wraps;
    previous_ticks = ticks;
    const TimestampNs t = clock.map(ticks, sensor.arrival(i));
    EXPECT_GT(t, previous) << "frame " << i;
    previous = t;
    // Device time keeps growing across wraps: frame i is i/30 s after frame 0.
    ASSERT_NEAR(clock.lastDeviceNs(), i * 1e9 / 30.0, 1000.0) << "frame " << i;
    // With constant latency the capture time is recovered up to that latency.
    ASSERT_NEAR(static_cast<double>(t - sensor.capture(i)), 8e6, 1e3) << "frame " << i;
  }
  EXPECT_EQ(wraps, 3);
}

TEST(DeviceClock, SmallBackwardStepsAreNotWraps) {
  DeviceClock clock;
  clock.map(1'000'000, kEpoch);
  clock.map(3'000'000, kEpoch + 33'000'000);
  // A colour stamp from slightly earlier than the last depth stamp.
  const TimestampNs t = clock.map(2'000'000, kEpoch + 34'000'000);
  EXPECT_NEAR(static_cast<double>(clock.lastDeviceNs()), 1'000'000 / kTick * 1e9, 1.0);
  EXPECT_LT(t, kEpoch + 34'000'000);
}

TEST(DeviceClock, FollowsDriftWithoutLag) {
  // A crystal 80 ppm fast: over 10 minutes the device clock gains 48 ms on the host.
  for (double drift : {80.0, -120.0}) {
    SimulatedSensor sensor{.drift_ppm = drift, .first_ticks = 4'000'000'000u};
    DeviceClock clock;
    double worst_ms = 0.0;
    for (int i = 0; i < 10 * 60 * 30; ++i) {
      const TimestampNs t = clock.map(sensor.ticks(i), sensor.arrival(i));
      if (i < 100) continue;
      // Latency is 8-10 ms: the filter should sit near its median, 9 ms.
      const double error_ms = (t - sensor.capture(i)) / 1e6 - 9.0;
      worst_ms = std::max(worst_ms, std::abs(error_ms));
    }
    EXPECT_LT(worst_ms, 1.0) << "drift " << drift << " ppm";
    EXPECT_NEAR(clock.driftPpm(), -drift, 30.0) << "drift " << drift << " ppm";
  }
}

TEST(DeviceClock, AFixedMedianWouldLagUnderDriftButTheLineDoesNot) {
  // Same as above with a tiny window: lag of a plain median would be window/2 * drift.
  SimulatedSensor sensor{.drift_ppm = 400.0, .jitter_ms = 0.0};
  DeviceClock clock(DeviceClockParams{.window = 300});
  TimestampNs t = 0;
  int i = 0;
  for (; i < 3000; ++i) t = clock.map(sensor.ticks(i), sensor.arrival(i));
  --i;
  // A plain median over 300 samples (10 s) would be 2 ms off at 400 ppm.
  EXPECT_NEAR((t - sensor.capture(i)) / 1e6, 8.0, 0.2);
}

TEST(DeviceClock, IgnoresOutliers) {
  SimulatedSensor sensor{.drift_ppm = 50.0, .outlier_rate = 0.1, .outlier_ms = 200.0};
  DeviceClock clock;
  double worst_ms = 0.0;
  for (int i = 0; i < 5 * 60 * 30; ++i) {
    const TimestampNs t = clock.map(sensor.ticks(i), sensor.arrival(i));
    if (i < 100) continue;
    worst_ms = std::max(worst_ms, std::abs((t - sensor.capture(i)) / 1e6 - 9.0));
  }
  // 10% of frames arrive 200 ms late; mapped times stay within ~1.5 ms of the truth.
  EXPECT_LT(worst_ms, 1.5);
}

TEST(DeviceClock, MappedTimesAreEvenlySpacedDespiteJitter) {
  SimulatedSensor sensor{.jitter_ms = 6.0};
  DeviceClock clock;
  TimestampNs previous = 0;
  for (int i = 0; i < 900; ++i) {
    const TimestampNs t = clock.map(sensor.ticks(i), sensor.arrival(i));
    if (i > 200) {
      EXPECT_NEAR((t - previous) / 1e6, 1000.0 / 30.0, 0.5) << i;
    }
    previous = t;
  }
}

TEST(DeviceClock, ResetForgetsTheOldDevice) {
  DeviceClock clock;
  for (int i = 0; i < 50; ++i) clock.map(1000u + i * 2'000'000u, kEpoch + i * 33'333'333);
  clock.reset();
  EXPECT_EQ(clock.samples(), 0u);
  EXPECT_EQ(clock.map(5, kEpoch + 10'000'000'000), kEpoch + 10'000'000'000);
}

TEST(DeviceClock, SixtyFourBitMicrosecondCounters) {
  // OpenNI2 stamps frames in microseconds on a 64-bit counter: nothing wraps.
  DeviceClock clock(DeviceClockParams{.tick_hz = 1e6, .counter_bits = 64});
  const std::uint64_t start = 5'000'000'000'000ull;
  TimestampNs t = 0;
  for (int i = 0; i < 100; ++i) {
    t = clock.map(start + static_cast<std::uint64_t>(i) * 33'333,
                  kEpoch + TimestampNs{i} * 33'333'000 + 5'000'000);
  }
  EXPECT_NEAR((t - (kEpoch + TimestampNs{99} * 33'333'000)) / 1e6, 5.0, 0.01);
}

}  // namespace
}  // namespace shapesense
