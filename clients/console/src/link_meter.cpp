#include "link_meter.h"

namespace shapesense::console {

void LinkMeter::received(std::size_t bytes, Clock::time_point now) {
  std::lock_guard lock(mutex_);
  arrivals_.emplace_back(now, bytes);
  total_ += bytes;
  forgetBefore(now - std::chrono::seconds(1));
}

std::size_t LinkMeter::bytesLastSecond(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  forgetBefore(now - std::chrono::seconds(1));
  return total_;
}

void LinkMeter::forgetBefore(Clock::time_point cutoff) {
  while (!arrivals_.empty() && arrivals_.front().first < cutoff) {
    total_ -= arrivals_.front().second;
    arrivals_.pop_front();
  }
}

}  // namespace shapesense::console
