// The pipeline's priority against gRPC's and the queries': runAtNice, and the daemon starting
// gRPC's threads at --grpc-nice, its query workers at --query-nice and its pipeline threads at
// --pipeline-nice (where the system allows it).

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

/// Whether this process may raise a thread's priority to `nice` (root, CAP_SYS_NICE or
/// RLIMIT_NICE).
bool mayRaiseTo(int nice) {
  bool allowed = false;
  std::thread probe([&] { allowed = setThisThreadNice(nice); });
  probe.join();
  return allowed;
}

DaemonOptions smallDaemon(const char* name) {
  DaemonOptions options;
  options.source = "tum:" + testing::makeSmallRecording(name, 5).string();
  options.loop = true;
  options.listen = "127.0.0.1:0";
  options.detectors.bowls = false;
  return options;
}

bool grpcAlreadyRuns(const std::map<pid_t, std::pair<std::string, int>>& threads) {
  for (const auto& [tid, thread] : threads) {
    if (thread.first.rfind("grpc", 0) == 0 || thread.first == "timer_manager") return true;
  }
  return false;
}

TEST(Daemon, GrpcThreadsRunAtGrpcNiceQueriesAtQueryNiceAndThePipelineAtPipelineNice) {
  const auto before = threadsOfThisProcess();
  if (grpcAlreadyRuns(before)) GTEST_SKIP() << "gRPC already runs in this process";
  const int own = niceOf(gettid());
  ASSERT_LT(own, 7);
  DaemonOptions options = smallDaemon("thread_priority");
  options.limits.grpc_nice = 7;
  options.limits.queries.nice = 9;
  options.pipeline.thread_nice = mayRaiseTo(-3) ? -3 : own;
  Daemon daemon(options);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int grpc_threads = 0, pipeline_threads = 0, query_workers = 0;
  for (const auto& [tid, thread] : threadsOfThisProcess()) {
    if (before.count(tid)) continue;
    const auto& [name, nice] = thread;
    if (name == "ss-capture" || name == "ss-detect") {
      EXPECT_EQ(nice, options.pipeline.thread_nice) << name;
      ++pipeline_threads;
    } else if (name == "ss-query") {
      EXPECT_EQ(nice, 9) << name;
      ++query_workers;
    } else {
      EXPECT_EQ(nice, 7) << name;
      ++grpc_threads;
    }
  }
  EXPECT_GE(grpc_threads, 3) << "gRPC's timer, executor and server threads";
  EXPECT_GE(pipeline_threads, 2) << "the capture and detector threads (and those they start)";
  EXPECT_GE(query_workers, 1);
}

TEST(Daemon, APipelinePriorityTheSystemRefusesLeavesThePipelineRunning) {
  if (mayRaiseTo(-20)) GTEST_SKIP() << "this process may raise priorities (root or CAP_SYS_NICE)";
  const auto before = threadsOfThisProcess();
  const int own = niceOf(gettid());
  DaemonOptions options = smallDaemon("thread_priority_refused");
  options.pipeline.thread_nice = -20;
  Daemon daemon(options);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int pipeline_threads = 0;
  for (const auto& [tid, thread] : threadsOfThisProcess()) {
    if (before.count(tid)) continue;
    if (thread.first != "ss-capture" && thread.first != "ss-detect") continue;
    EXPECT_EQ(thread.second, own) << thread.first;
    ++pipeline_threads;
  }
  EXPECT_GE(pipeline_threads, 2);
  EXPECT_TRUE(daemon.health().healthy);
}

}  // namespace
}  // namespace shapesense
