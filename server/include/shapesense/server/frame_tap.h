#pragma once
// Every frame the source delivers, as the capture thread caches it (processed or not), handed
// to whoever listens: the Record RPC writes them to disk. Listeners run on the capture thread
// and must only hand the frame over (queue it), never block.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>

#include "shapesense/core/geometry/frame.h"

namespace shapesense {

class FrameTap {
 public:
  using Listener = std::function<void(const std::shared_ptr<const Frame>&)>;

  /// Returns an id for unsubscribe().
  std::uint64_t subscribe(Listener listener) {
    std::lock_guard lock(mutex_);
    listeners_.emplace(next_id_, std::move(listener));
    return next_id_++;
  }
  /// After it returns the listener is not called again.
  void unsubscribe(std::uint64_t id) {
    std::lock_guard lock(mutex_);
    listeners_.erase(id);
  }
  void publish(const std::shared_ptr<const Frame>& frame) {
    std::lock_guard lock(mutex_);
    for (auto& [id, listener] : listeners_) listener(frame);
  }

 private:
  std::mutex mutex_;
  std::map<std::uint64_t, Listener> listeners_;
  std::uint64_t next_id_ = 1;
};

/// Unsubscribes on destruction.
class FrameTapSubscription {
 public:
  FrameTapSubscription(FrameTap& tap, FrameTap::Listener listener)
      : tap_(tap), id_(tap.subscribe(std::move(listener))) {}
  ~FrameTapSubscription() { tap_.unsubscribe(id_); }
  FrameTapSubscription(const FrameTapSubscription&) = delete;
  FrameTapSubscription& operator=(const FrameTapSubscription&) = delete;

 private:
  FrameTap& tap_;
  std::uint64_t id_;
};

}  // namespace shapesense
