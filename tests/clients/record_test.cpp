// `shapesense record`: with --source the CLI records by itself; without, the daemon records
// through the Record RPC. Either way the recording replays bit-identically.

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "commands.h"
#include "recording_fixture.h"
#include "server_fixture.h"
#include "shapesense/driver/replay_source.h"
#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

void runRecord(cli::GlobalOptions& global, std::vector<std::string> args) {
  CLI::App app;
  app.add_option("--server", global.server);
  cli::addRecordCommand(app, global);
  args.insert(args.begin(), "record");
  std::reverse(args.begin(), args.end());  // CLI11 takes a reversed vector
  app.parse(args);
}

using testing::expectSameFrame;
using testing::replayAll;

TEST(RecordCommand, WithSourceRecordsARecordingThatReplaysBitIdentically) {
  const fs::path original = testing::makeSmallRecording("record_cli_original", 6);
  const fs::path out = testing::scratchDir("record_cli") / "copy";
  cli::GlobalOptions global;
  runRecord(global,
            {"--source", "tum:" + original.string(), "--out", out.string(), "--seconds", "0"});
  const auto want = replayAll(original);
  const auto got = replayAll(out);
  ASSERT_EQ(want.size(), 6u);
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    expectSameFrame(got[i], want[i], want[i].timestamp_ns, want[i].intrinsics);
  }
}

TEST(RecordCommand, WithSourceRefusesANonEmptyDirectory) {
  const fs::path original = testing::makeSmallRecording("record_cli_original2", 2);
  const fs::path out = testing::scratchDir("record_cli_full");
  std::ofstream(out / "keep.txt") << "x";
  cli::GlobalOptions global;
  try {
    runRecord(global, {"--source", "tum:" + original.string(), "--out", out.string()});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("is not empty"));
  }
  EXPECT_FALSE(fs::exists(out / "depth.txt"));
}

TEST(RecordCommand, WithoutSourceTheDaemonRecords) {
  testing::TestServer srv(64);
  const fs::path out = srv.recordRoot() / "rec";
  cli::GlobalOptions global;
  global.server = "127.0.0.1:" + std::to_string(srv.port());
  std::atomic<bool> finished{false};
  std::exception_ptr failure;
  std::thread recorder([&] {
    try {
      runRecord(global, {"--out", "rec", "--seconds", "0.5"});
    } catch (...) {
      failure = std::current_exception();
    }
    finished = true;
  });
  // The daemon records frames delivered while the call runs; feed until the command returns.
  TimestampNs t = testing::kServerT0;
  while (!finished) {
    srv.add(t);
    t += testing::kFramePeriodNs;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  recorder.join();
  if (failure) std::rethrow_exception(failure);
  const auto got = replayAll(out);
  ASSERT_GE(got.size(), 5u);
  // Consecutive frames of those added, each bit-identical to its original.
  const auto& added = srv.added();
  std::size_t first = 0;
  while (first < added.size() &&
         (added[first]->timestamp_ns + 500) / 1000 * 1000 != got[0].timestamp_ns)
    ++first;
  ASSERT_LT(first + got.size(), added.size() + 1);
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const Frame& want = *added[first + i];
    expectSameFrame(got[i], want, (want.timestamp_ns + 500) / 1000 * 1000,
                    added[first]->intrinsics);
  }
}

TEST(RecordCommand, WithoutSourceReportsTheDaemonsRefusal) {
  testing::TestServer srv(4);
  fs::create_directories(srv.recordRoot() / "full");
  std::ofstream(srv.recordRoot() / "full" / "keep.txt") << "x";
  cli::GlobalOptions global;
  global.server = "127.0.0.1:" + std::to_string(srv.port());
  const auto expectRefusal = [&](const std::string& out, grpc::StatusCode code,
                                 const std::string& text) {
    try {
      runRecord(global, {"--out", out, "--seconds", "1"});
      ADD_FAILURE() << "expected an error for " << out;
    } catch (const cli::RpcError& e) {
      EXPECT_EQ(e.code(), code) << out;
      EXPECT_THAT(e.what(), HasSubstr(text));
    }
  };
  expectRefusal("full", grpc::StatusCode::FAILED_PRECONDITION, "is not empty");
  // The name goes to the daemon as given: relative to its recordings root, never out of it.
  expectRefusal("../escaped", grpc::StatusCode::INVALID_ARGUMENT, "contains '..'");
  expectRefusal((srv.recordRoot() / "abs").string(), grpc::StatusCode::INVALID_ARGUMENT,
                "is absolute");
  EXPECT_FALSE(fs::exists(srv.recordRoot().parent_path() / "escaped"));
  EXPECT_FALSE(fs::exists(srv.recordRoot() / "abs"));
}

}  // namespace
}  // namespace shapesense
