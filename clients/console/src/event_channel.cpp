#include "event_channel.h"

namespace shapesense::console {

std::string SseEvent::wire() const { return "event: " + name + "\ndata: " + json + "\n\n"; }

bool EventChannel::pushScene(SseEvent event) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return closed_ || !scene_; });
  if (closed_) return false;
  scene_ = std::move(event);
  changed_.notify_all();
  return true;
}

void EventChannel::pushNotice(SseEvent event) {
  std::lock_guard lock(mutex_);
  if (closed_) return;
  if (notices_.size() >= kMaxNotices) notices_.pop_front();
  notices_.push_back(std::move(event));
  changed_.notify_all();
}

std::optional<SseEvent> EventChannel::pop(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return closed_ || scene_ || !notices_.empty(); });
  if (closed_) return std::nullopt;
  std::optional<SseEvent> event;
  if (!notices_.empty()) {
    event = std::move(notices_.front());
    notices_.pop_front();
  } else if (scene_) {
    event = std::move(scene_);
    scene_.reset();
  }
  changed_.notify_all();
  return event;
}

void EventChannel::close() {
  std::lock_guard lock(mutex_);
  closed_ = true;
  changed_.notify_all();
}

bool EventChannel::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

void EventChannels::add(const std::shared_ptr<EventChannel>& channel) {
  std::lock_guard lock(mutex_);
  channels_.insert(channel);
}

void EventChannels::remove(const std::shared_ptr<EventChannel>& channel) {
  std::lock_guard lock(mutex_);
  channels_.erase(channel);
}

void EventChannels::broadcast(const SseEvent& event) {
  std::lock_guard lock(mutex_);
  for (const auto& channel : channels_) channel->pushNotice(event);
}

void EventChannels::closeAll() {
  std::lock_guard lock(mutex_);
  for (const auto& channel : channels_) channel->close();
}

}  // namespace shapesense::console
