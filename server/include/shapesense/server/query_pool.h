#pragma once
// The threads heavy queries run on (EstimateBox, GetFrame and the detector queries). A fixed
// number of workers and a bounded queue: a query that finds the queue full is refused at once
// (the caller answers RESOURCE_EXHAUSTED) instead of waiting behind work it cannot catch up
// with, and one that waited longer than max_wait (the queue held slow queries) is refused when
// a worker reaches it, so an answered query never waited long. Sized below the core count, the
// pool leaves the pipeline's detector thread a core of its own however many clients call; its
// workers run at a lower priority (nice) for the same reason.

#include <chrono>
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
  /// Longest a query may wait for a worker; one that waited longer is refused.
  std::chrono::milliseconds max_wait{5};
  /// The workers' nice value (0..19), so the pipeline wins a contended core.
  int nice = 5;
};

class QueryPool {
 public:
  explicit QueryPool(const QueryPoolOptions& options);
  /// Runs what is queued, then joins the workers.
  ~QueryPool();
  QueryPool(const QueryPool&) = delete;
  QueryPool& operator=(const QueryPool&) = delete;

  /// A queued task, called on a worker with true, or with false when it waited past max_wait
  /// behind other tasks (then it should only answer that it was refused). A task that found a
  /// worker idle always runs: a late start then is the machine's, not the queue's.
  using Task = std::function<void(bool run)>;

  /// Queues `task` for a worker; false (and `task` is dropped) when `queue` tasks already wait
  /// beyond those the idle workers are about to take, or the pool is stopping.
  bool trySubmit(Task task);
  /// Stops taking tasks; the workers finish what is queued and exit.
  void stop();

  int workers() const { return static_cast<int>(threads_.size()); }
  std::size_t capacity() const { return capacity_; }
  std::chrono::milliseconds maxWait() const { return max_wait_; }

  /// The worker count `workers` = 0 means on this machine.
  static int defaultWorkers();

 private:
  void run(int nice);

  struct Queued {
    Task task;
    std::chrono::steady_clock::time_point since;
    bool behind_others;  ///< no worker was idle for it when it came
  };

  const std::size_t capacity_;
  const std::chrono::milliseconds max_wait_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Queued> queue_;
  /// Workers waiting for a task: a task they will take at once does not count as queued.
  std::size_t idle_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace shapesense
