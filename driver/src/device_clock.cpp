#include "shapesense/driver/device_clock.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace shapesense {
namespace {

double medianOf(std::vector<double> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  if (values.size() % 2 == 1) return *mid;
  const double upper = *mid;
  const double lower = *std::max_element(values.begin(), mid);
  return 0.5 * (lower + upper);
}

}  // namespace

DeviceClock::DeviceClock(DeviceClockParams params) : params_(params) {
  if (!(params_.tick_hz > 0.0)) throw std::invalid_argument("DeviceClock: tick_hz must be > 0");
  if (params_.counter_bits < 1 || params_.counter_bits > 64) {
    throw std::invalid_argument("DeviceClock: counter_bits must be 1-64");
  }
  if (params_.window < 1 || params_.block < 1 || params_.drift_blocks < 2) {
    throw std::invalid_argument("DeviceClock: window and block must be >= 1, drift_blocks >= 2");
  }
  mask_ = params_.counter_bits == 64 ? ~std::uint64_t{0}
                                     : (std::uint64_t{1} << params_.counter_bits) - 1;
}

void DeviceClock::reset() {
  last_raw_.reset();
  last_ticks_ = 0;
  last_device_ns_ = 0;
  samples_.clear();
  current_block_.clear();
  blocks_.clear();
  anchor_device_ns_ = 0;
  offset_base_ = 0;
  anchor_offset_ = 0.0;
  drift_ = 0.0;
}

std::int64_t DeviceClock::unwrap(std::uint64_t raw_ticks) const {
  raw_ticks &= mask_;
  if (!last_raw_) return 0;
  // Signed difference modulo 2^bits: the nearest way round the counter.
  std::uint64_t diff = (raw_ticks - *last_raw_) & mask_;
  std::int64_t signed_diff;
  if (params_.counter_bits == 64) {
    signed_diff = static_cast<std::int64_t>(diff);
  } else {
    const std::uint64_t half = std::uint64_t{1} << (params_.counter_bits - 1);
    signed_diff = diff >= half
                      ? static_cast<std::int64_t>(diff) - static_cast<std::int64_t>(half << 1)
                      : static_cast<std::int64_t>(diff);
  }
  return last_ticks_ + signed_diff;
}

TimestampNs DeviceClock::map(std::uint64_t raw_ticks, TimestampNs host_arrival_ns) {
  const std::int64_t ticks = unwrap(raw_ticks);
  const auto device_ns = static_cast<std::int64_t>(std::llround(ticks * 1e9 / params_.tick_hz));
  if (!last_raw_) offset_base_ = host_arrival_ns - device_ns;
  last_raw_ = raw_ticks & mask_;
  last_ticks_ = ticks;
  last_device_ns_ = device_ns;
  const Sample sample{device_ns, host_arrival_ns - device_ns};
  samples_.push_back(sample);
  while (samples_.size() > params_.window) samples_.pop_front();
  current_block_.push_back(sample);
  if (current_block_.size() >= params_.block) updateDrift();
  refit();
  return *toHost(raw_ticks);
}

void DeviceClock::updateDrift() {
  std::vector<double> times, offsets;
  for (const auto& s : current_block_) {
    times.push_back(static_cast<double>(s.device_ns));
    offsets.push_back(static_cast<double>(s.offset_ns - offset_base_));
  }
  current_block_.clear();
  blocks_.push_back({medianOf(std::move(times)), medianOf(std::move(offsets))});
  while (blocks_.size() > params_.drift_blocks) blocks_.pop_front();
  if (blocks_.size() < 2) return;
  std::vector<double> slopes;
  slopes.reserve(blocks_.size() * (blocks_.size() - 1) / 2);
  for (std::size_t i = 0; i < blocks_.size(); ++i) {
    for (std::size_t j = i + 1; j < blocks_.size(); ++j) {
      const double dt = blocks_[j].device_ns - blocks_[i].device_ns;
      if (dt > 0) slopes.push_back((blocks_[j].offset_ns - blocks_[i].offset_ns) / dt);
    }
  }
  if (slopes.empty()) return;
  const double limit = params_.max_drift_ppm * 1e-6;
  drift_ = std::clamp(medianOf(std::move(slopes)), -limit, limit);
}

void DeviceClock::refit() {
  // Median of the recent offsets, each moved along the drift line to the newest sample.
  anchor_device_ns_ = samples_.back().device_ns;
  std::vector<double> detrended;
  detrended.reserve(samples_.size());
  for (const auto& s : samples_) {
    detrended.push_back(static_cast<double>(s.offset_ns - offset_base_) +
                        drift_ * static_cast<double>(anchor_device_ns_ - s.device_ns));
  }
  anchor_offset_ = medianOf(std::move(detrended));
}

std::optional<TimestampNs> DeviceClock::toHost(std::uint64_t raw_ticks) const {
  if (!last_raw_) return std::nullopt;
  const std::int64_t ticks = unwrap(raw_ticks);
  const auto device_ns = static_cast<std::int64_t>(std::llround(ticks * 1e9 / params_.tick_hz));
  const double offset =
      anchor_offset_ + drift_ * static_cast<double>(device_ns - anchor_device_ns_);
  return device_ns + offset_base_ + static_cast<std::int64_t>(std::llround(offset));
}

}  // namespace shapesense
