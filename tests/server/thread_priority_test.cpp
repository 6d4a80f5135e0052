// The detector thread's priority against gRPC's: runAtNice, and the daemon starting gRPC's
// threads at --grpc-nice while its pipeline runs at the process's own priority.

#include "shapesense/server/thread_priority.h"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>

#include "recording_fixture.h"
#include "shapesense/server/daemon.h"

namespace shapesense {
namespace {

int niceOf(pid_t tid) {
  errno = 0;
  return getpriority(PRIO_PROCESS, static_cast<id_t>(tid));
}

/// Thread id -> (name, nice) of every thread of this process.
std::map<pid_t, std::pair<std::string, int>> threadsOfThisProcess() {
  std::map<pid_t, std::pair<std::string, int>> threads;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task")) {
    const pid_t tid = std::stoi(entry.path().filename().string());
    std::ifstream comm(entry.path() / "comm");
    std::string name;
    std::getline(comm, name);
    threads[tid] = {name, niceOf(tid)};
  }
  return threads;
}

TEST(RunAtNice, WorkAndTheThreadsItStartsRunAtThatNiceTheCallerDoesNot) {
  const int own = niceOf(gettid());
  ASSERT_LT(own, 7) << "the test needs room to lower its priority";
  int work_nice = -100, child_nice = -100;
  runAtNice(7, [&] {
    work_nice = niceOf(gettid());
    std::thread child([&] { child_nice = niceOf(gettid()); });
    child.join();
  });
  EXPECT_EQ(work_nice, 7);
  EXPECT_EQ(child_nice, 7);
  EXPECT_EQ(niceOf(gettid()), own);
}

TEST(RunAtNice, RethrowsWhatTheWorkThrew) {
  EXPECT_THROW(runAtNice(3, [] { throw std::runtime_error("no"); }), std::runtime_error);
}

TEST(Daemon, GrpcThreadsRunAtGrpcNiceAndThePipelineAtTheDaemonsOwn) {
  const auto before = threadsOfThisProcess();
  for (const auto& [tid, thread] : before) {
    if (thread.first.rfind("grpc", 0) == 0 || thread.first == "timer_manager") {
      GTEST_SKIP() << "gRPC already runs in this process; ctest runs this test alone";
    }
  }
  const int own = niceOf(gettid());
  ASSERT_LT(own, 7);
  DaemonOptions options;
  options.source = "tum:" + testing::makeSmallRecording("thread_priority", 5).string();
  options.loop = true;
  options.listen = "127.0.0.1:0";
  options.limits.grpc_nice = 7;
  options.detectors.bowls = false;
  Daemon daemon(options);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int grpc_threads = 0, at_own = 0;
  for (const auto& [tid, thread] : threadsOfThisProcess()) {
    if (before.count(tid)) continue;
    const auto& [name, nice] = thread;
    const bool query_worker = nice == options.limits.queries.nice;
    if (nice == own) {
      ++at_own;  // the pipeline's capture and detector threads
    } else if (!query_worker) {
      EXPECT_EQ(nice, 7) << name;
    }
    grpc_threads += nice == 7;
  }
  EXPECT_GE(grpc_threads, 3) << "gRPC's timer, executor and server threads";
  EXPECT_GE(at_own, 2) << "the capture and detector threads";
}

}  // namespace
}  // namespace shapesense
