#include "shapesense/server/query_pool.h"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "shapesense/server/thread_priority.h"

namespace shapesense {

int QueryPool::defaultWorkers() {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, cores - 1);
}

QueryPool::QueryPool(const QueryPoolOptions& options)
    : capacity_(options.queue), max_wait_(options.max_wait) {
  const int workers = options.workers > 0 ? options.workers : defaultWorkers();
  threads_.reserve(static_cast<std::size_t>(workers));
  for (int i = 0; i < workers; ++i)
    threads_.emplace_back([this, nice = options.nice] { run(nice); });
}

QueryPool::~QueryPool() { stop(); }

bool QueryPool::trySubmit(Task task) {
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || queue_.size() >= capacity_ + idle_) return false;
    queue_.push_back({std::move(task), now, queue_.size() >= idle_});
  }
  ready_.notify_one();
  return true;
}

void QueryPool::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
  }
  ready_.notify_all();
  for (auto& thread : threads_) {
    if (thread.joinable()) thread.join();
  }
  threads_.clear();
}

void QueryPool::run(int nice) {
  nameThisThread("ss-query");
  if (nice > 0 && !setThisThreadNice(nice)) {
    spdlog::debug("query worker: cannot set nice {}", nice);
  }
  std::unique_lock lock(mutex_);
  while (true) {
    ++idle_;
    ready_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    --idle_;
    if (queue_.empty()) return;  // stopping, nothing left
    Queued next = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    next.task(!next.behind_others || std::chrono::steady_clock::now() - next.since <= max_wait_);
    lock.lock();
  }
}

}  // namespace shapesense
