#include "shapesense/server/thread_priority.h"

#include <sys/resource.h>
#include <unistd.h>

#include <exception>
#include <thread>

namespace shapesense {

bool setThisThreadNice(int nice) {
  // PRIO_PROCESS with a thread id addresses that one thread on Linux.
  return setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), nice) == 0;
}

void runAtNice(int nice, const std::function<void()>& work) {
  std::exception_ptr failure;
  std::thread thread([&] {
    setThisThreadNice(nice);
    try {
      work();
    } catch (...) {
      failure = std::current_exception();
    }
  });
  thread.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace shapesense
