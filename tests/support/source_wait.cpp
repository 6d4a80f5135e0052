#include "source_wait.h"

#include <condition_variable>
#include <mutex>
#include <stop_token>
#include <thread>

namespace shapesense::testing {

SourceEvent nextWithin(FrameSource& source, std::chrono::milliseconds limit) {
  std::stop_source stop;
  // The watchdog asks next() to stop after `limit`; it ends early once next() has returned.
  std::jthread watchdog([&stop, limit](std::stop_token cancelled) {
    std::mutex m;
    std::condition_variable_any cv;
    std::unique_lock lock(m);
    if (!cv.wait_for(lock, cancelled, limit, [] { return false; })) stop.request_stop();
  });
  return source.next(stop.get_token());
}

void waitUntilStopped(std::stop_token stop) {
  std::mutex mutex;
  std::condition_variable_any cv;
  std::unique_lock lock(mutex);
  cv.wait(lock, stop, [] { return false; });
}

}  // namespace shapesense::testing
