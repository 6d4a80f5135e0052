#pragma once
// The load the console puts on the link to the daemon: bytes of the gRPC messages it received in
// the last second (what an operator on a thin link wants to see).

#include <chrono>
#include <cstddef>
#include <deque>
#include <mutex>
#include <utility>

namespace shapesense::console {

class LinkMeter {
 public:
  using Clock = std::chrono::steady_clock;

  /// Counts a received message of `bytes` (its serialized size).
  void received(std::size_t bytes, Clock::time_point now = Clock::now());
  /// Bytes received in the second before `now`.
  std::size_t bytesLastSecond(Clock::time_point now = Clock::now());

 private:
  void forgetBefore(Clock::time_point cutoff);

  std::mutex mutex_;
  std::deque<std::pair<Clock::time_point, std::size_t>> arrivals_;
  std::size_t total_ = 0;
};

}  // namespace shapesense::console
