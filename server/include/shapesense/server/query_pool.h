#pragma once
// The threads heavy queries run on (EstimateBox, GetFrame and the detector queries). A fixed
// number of workers and a bounded queue: a query that finds the queue full is refused at once
// (the caller answers RESOURCE_EXHAUSTED) instead of waiting behind work it cannot catch up
// with. Sized below the core count, it leaves the pipeline's detector thread a core of its
// own however many clients call; its workers run at a lower priority (nice) for the same reason.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace shapesense {

struct QueryPoolOptions {
  /// Worker threads; 0 = one fewer than the cores, at least 1.
  int workers = 0;
  /// Queries waiting for a worker; one more is refused.
  std::size_t queue = 8;
  /// Added to the workers' nice value (0..19), so the pipeline wins a contended core.
  int nice = 10;
};

class QueryPool {
 public:
  explicit QueryPool(const QueryPoolOptions& options);
  /// Runs what is queued, then joins the workers.
  ~QueryPool();
  QueryPool(const QueryPool&) = delete;
  QueryPool& operator=(const QueryPool&) = delete;

  /// Queues `task` for a worker; false (and `task` is dropped) when `queue` tasks already wait
  /// beyond those the idle workers are about to take, or the pool is stopping.
  bool trySubmit(std::function<void()> task);
  /// Stops taking tasks; the workers finish what is queued and exit.
  void stop();

  int workers() const { return static_cast<int>(threads_.size()); }
  std::size_t capacity() const { return capacity_; }

  /// The worker count `workers` = 0 means on this machine.
  static int defaultWorkers();

 private:
  void run(int nice);

  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> queue_;
  /// Workers waiting for a task: a task they will take at once does not count as queued.
  std::size_t idle_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace shapesense
