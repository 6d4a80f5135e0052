#pragma once
// Maps a sensor's own frame counter to host time (ns since the epoch).
//
// Two steps:
//  1. Unwrap: the Kinect v1 stamps frames with a 32-bit counter at 60 MHz that wraps every
//     2^32 / 60e6 = 71.6 s. Each stamp is placed at the previous one plus the signed modular
//     difference, so wraps are crossed and small backward steps (depth and colour stamps
//     interleaving) stay small. A gap of more than half the counter range (35.8 s) cannot be
//     told from a wrap; sources reset() the clock when they reopen a device.
//  2. Offset filter: every sample gives offset = host arrival time - device time, which is the
//     true clock offset plus a positive, jittery transport latency (with occasional outliers
//     when USB or the host stalls). Two time scales:
//     - drift (the 60 MHz crystal against the host clock, typically tens of ppm) is the
//       Theil-Sen slope (median of pairwise slopes) through block medians: every `block`
//       samples give one (median device time, median offset) point, the last `drift_blocks`
//       points are kept (about a minute at the defaults);
//     - the offset itself is the median over the last `window` samples after removing that
//       slope, evaluated at the newest sample, so it has no lag under drift.
//     Medians make outliers harmless as long as fewer than half the samples are late.
// Mapped times are not forced to be monotonic here; sources do that across reconnects.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "shapesense/core/geometry/frame.h"

namespace shapesense {

struct DeviceClockParams {
  double tick_hz = 60e6;    ///< counter frequency. Default 60 MHz (Kinect v1).
  int counter_bits = 32;    ///< counter width, 1-64. Default 32 (Kinect v1).
  std::size_t window = 90;  ///< samples in the offset median (3 s of one 30 Hz stream). Default 90.
  std::size_t block = 30;   ///< samples per drift point. Default 30.
  std::size_t drift_blocks = 60;  ///< drift points kept (60 x 30 samples ~ 1 min). Default 60.
  /// Drift estimates beyond this magnitude (parts per million) are clamped. Default 500.
  double max_drift_ppm = 500.0;
};

/// Not thread-safe; one per open device, fed from the thread that receives its frames.
class DeviceClock {
 public:
  /// Throws std::invalid_argument on tick_hz <= 0, counter_bits outside 1-64, window or
  /// block < 1, drift_blocks < 2.
  explicit DeviceClock(DeviceClockParams params = {});

  /// Records one frame: its raw device counter and the host time it arrived. Returns the
  /// host-clock capture time of that frame.
  TimestampNs map(std::uint64_t raw_ticks, TimestampNs host_arrival_ns);

  /// Host time of a device counter value (unwrapped against the latest sample) with the
  /// current offset estimate, without recording a sample. nullopt before the first sample.
  std::optional<TimestampNs> toHost(std::uint64_t raw_ticks) const;

  /// Unwrapped device time (ns since the first sample) of the latest sample.
  std::int64_t lastDeviceNs() const { return last_device_ns_; }
  /// Current drift estimate (host seconds per device second - 1), in ppm.
  double driftPpm() const { return drift_ * 1e6; }
  std::size_t samples() const { return samples_.size(); }

  /// Forgets everything (a new device, or the same one after a reset of its counter).
  void reset();

 private:
  struct Sample {
    std::int64_t device_ns;  // unwrapped, relative to the first sample
    std::int64_t offset_ns;  // host arrival - device_ns
  };
  struct BlockPoint {
    double device_ns;  // median device time of the block, relative to the first sample
    double offset_ns;  // median offset of the block, relative to offset_base_
  };
  std::int64_t unwrap(std::uint64_t raw_ticks) const;
  void updateDrift();
  void refit();

  DeviceClockParams params_;
  std::uint64_t mask_;
  std::optional<std::uint64_t> last_raw_;
  std::int64_t last_ticks_ = 0;  // unwrapped ticks of the latest sample
  std::int64_t last_device_ns_ = 0;
  std::deque<Sample> samples_;
  std::vector<Sample> current_block_;
  std::deque<BlockPoint> blocks_;
  // The fitted line: offset(t) = offset_base_ + anchor_offset_ + drift_ * (t - anchor_device_ns_)
  // (the integer base keeps ns precision at epoch scale).
  std::int64_t anchor_device_ns_ = 0;
  std::int64_t offset_base_ = 0;  // offset of the first sample: doubles stay small
  double anchor_offset_ = 0.0;
  double drift_ = 0.0;
};

}  // namespace shapesense
