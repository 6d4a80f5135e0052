#pragma once
// The events bound for one open page (one /api/events connection), and the set of open pages.

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace shapesense::console {

/// One server-sent event: `event: <name>` and one line of JSON data.
struct SseEvent {
  std::string name;
  std::string json;
  /// The wire form: "event: NAME\ndata: JSON\n\n".
  std::string wire() const;
};

/// What is waiting for one page. Scene updates wait in a single slot and their producer waits
/// for it to empty: a page that reads slowly then holds up the WatchScene reader, gRPC's flow
/// control holds up the daemon, and the daemon keeps only the newest update for us (its deltas
/// are against what was sent, so nothing is lost but intermediate states). Other events are
/// few and small; the oldest go when more than kMaxNotices wait.
class EventChannel {
 public:
  static constexpr std::size_t kMaxNotices = 64;

  /// Waits until the scene slot is free (or the channel closed: returns false), then fills it.
  bool pushScene(SseEvent event);
  /// Queues a link, status or record event; never waits.
  void pushNotice(SseEvent event);
  /// The next event, notices first; nothing when `timeout` passed or the channel is closed.
  std::optional<SseEvent> pop(std::chrono::milliseconds timeout);
  /// Wakes every waiter; later pushes are dropped and pops return nothing.
  void close();
  bool closed() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<SseEvent> scene_;
  std::deque<SseEvent> notices_;
  bool closed_ = false;
};

/// The open pages, for events every page gets (recording progress).
class EventChannels {
 public:
  void add(const std::shared_ptr<EventChannel>& channel);
  void remove(const std::shared_ptr<EventChannel>& channel);
  void broadcast(const SseEvent& event);
  /// Closes every channel (the server stops).
  void closeAll();

 private:
  std::mutex mutex_;
  std::set<std::shared_ptr<EventChannel>> channels_;
};

}  // namespace shapesense::console
