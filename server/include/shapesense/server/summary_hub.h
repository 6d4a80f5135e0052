#pragma once
// Fans out every processed frame to Watch subscribers. Each subscriber has a bounded queue (by
// default one slot: the newest summary waits while the previous one is being written); when it
// is full the oldest pending entry is dropped and counted, so a slow client never slows the
// pipeline and never makes the daemon buffer without bound.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "shapesense/server/frame_cache.h"

namespace shapesense {

class Subscription {
 public:
  Subscription(std::size_t max_pending, std::function<void()> on_ready)
      : max_pending_(max_pending), on_ready_(std::move(on_ready)) {}

  struct Item {
    CachedFrame frame;
    std::uint64_t dropped_before = 0;  ///< entries lost since the previous item
  };

  /// Waits up to `timeout` for the next item. nullopt on timeout or once closed.
  std::optional<Item> pop(std::chrono::milliseconds timeout);
  /// The next item if one waits; never blocks.
  std::optional<Item> tryPop();
  /// An item waits (tryPop would return one); never blocks.
  bool hasPending() const;
  bool closed() const;

 private:
  friend class SummaryHub;
  void push(const CachedFrame& frame);
  void close();

  const std::size_t max_pending_;
  /// Called, without the subscription's lock, after each push and at close.
  const std::function<void()> on_ready_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<CachedFrame> pending_;
  std::uint64_t dropped_ = 0;
  bool closed_ = false;
};

class SummaryHub {
 public:
  /// Latest wins: the newest summary waits, older ones are dropped and counted.
  static constexpr std::size_t kDefaultMaxPending = 1;

  /// A new subscriber that receives every frame published from now on. `on_ready` (may be
  /// empty) is called on the publishing thread after each frame is queued and when the hub
  /// closes; it must be short and must not call the hub. After unsubscribe() returns it is
  /// never called again.
  std::shared_ptr<Subscription> subscribe(std::size_t max_pending = kDefaultMaxPending,
                                          std::function<void()> on_ready = {});
  void unsubscribe(const std::shared_ptr<Subscription>& subscription);
  /// Queues the frame for every subscriber; never blocks on a subscriber.
  void publish(const CachedFrame& frame);
  /// Closes every subscription (shutdown): their pop() returns at once.
  void closeAll();
  std::size_t subscribers() const;

 private:
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<Subscription>> subscribers_;
  bool closed_ = false;
};

}  // namespace shapesense
