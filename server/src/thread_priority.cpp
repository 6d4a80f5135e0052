#include "shapesense/server/thread_priority.h"

#include <pthread.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstring>
#include <exception>
#include <thread>

namespace shapesense {

bool setThisThreadNice(int nice) {
  // PRIO_PROCESS with a thread id addresses that one thread on Linux.
  return setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), nice) == 0;
}

int thisThreadNice() { return getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())); }

void nameThisThread(const char* name) {
  char kept[16] = {};
  std::strncpy(kept, name, sizeof kept - 1);
  pthread_setname_np(pthread_self(), kept);
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
