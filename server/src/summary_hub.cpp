#include "shapesense/server/summary_hub.h"

#include <algorithm>

namespace shapesense {

std::optional<Subscription::Item> Subscription::pop(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  ready_.wait_for(lock, timeout, [this] { return closed_ || !pending_.empty(); });
  if (closed_ || pending_.empty()) return std::nullopt;
  Item item{std::move(pending_.front()), dropped_};
  pending_.pop_front();
  dropped_ = 0;
  return item;
}

std::optional<Subscription::Item> Subscription::tryPop() {
  std::lock_guard lock(mutex_);
  if (pending_.empty()) return std::nullopt;
  Item item{std::move(pending_.front()), dropped_};
  pending_.pop_front();
  dropped_ = 0;
  return item;
}

bool Subscription::hasPending() const {
  std::lock_guard lock(mutex_);
  return !pending_.empty();
}

bool Subscription::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

void Subscription::push(const CachedFrame& frame) {
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
    if (pending_.size() == max_pending_) {
      pending_.pop_front();
      ++dropped_;
    }
    pending_.push_back(frame);
  }
  ready_.notify_one();
  if (on_ready_) on_ready_();
}

void Subscription::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  ready_.notify_all();
  if (on_ready_) on_ready_();
}

std::shared_ptr<Subscription> SummaryHub::subscribe(std::size_t max_pending,
                                                    std::function<void()> on_ready) {
  auto subscription =
      std::make_shared<Subscription>(std::max<std::size_t>(1, max_pending), std::move(on_ready));
  std::lock_guard lock(mutex_);
  if (closed_) {
    subscription->close();
  } else {
    subscribers_.push_back(subscription);
  }
  return subscription;
}

void SummaryHub::unsubscribe(const std::shared_ptr<Subscription>& subscription) {
  std::lock_guard lock(mutex_);
  std::erase(subscribers_, subscription);
}

void SummaryHub::publish(const CachedFrame& frame) {
  std::lock_guard lock(mutex_);
  for (const auto& subscriber : subscribers_) subscriber->push(frame);
}

void SummaryHub::closeAll() {
  std::lock_guard lock(mutex_);
  closed_ = true;
  for (const auto& subscriber : subscribers_) subscriber->close();
  subscribers_.clear();
}

std::size_t SummaryHub::subscribers() const {
  std::lock_guard lock(mutex_);
  return subscribers_.size();
}

}  // namespace shapesense
