// Record through a real in-process gRPC server: the frames delivered during the call are
// written in the TUM layout and replay bit-identically (depth, RGB, stamps to the microsecond,
// intrinsics); bad requests get the documented statuses.

#include <filesystem>
#include <fstream>
#include <future>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "recording_fixture.h"
#include "server_fixture.h"
#include "shapesense/driver/replay_source.h"
#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using testing::clientContext;
using ::testing::HasSubstr;
using testing::kFramePeriodNs;
using testing::kServerT0;
using testing::replayAll;
using testing::TestServer;

grpc::Status recordOnce(TestServer& srv, const std::string& dir, double seconds,
                        std::vector<v1::RecordProgress>* progress = nullptr) {
  v1::RecordRequest request;
  request.set_dir(dir);
  request.set_seconds(seconds);
  auto context = clientContext();
  auto reader = srv.stub().Record(context.get(), request);
  v1::RecordProgress message;
  while (reader->Read(&message)) {
    if (progress) progress->push_back(message);
  }
  return reader->Finish();
}

TimestampNs roundedToMicroseconds(TimestampNs t) { return (t + 500) / 1000 * 1000; }

/// Recordings keep stamps to the microsecond.
void expectSameFrame(const Frame& replayed, const Frame& original, const CameraIntrinsics& camera) {
  testing::expectSameFrame(replayed, original, roundedToMicroseconds(original.timestamp_ns),
                           camera);
}

TEST(Record, WritesTheFramesDeliveredDuringTheCallAndTheyReplayBitIdentically) {
  TestServer srv(16);
  srv.addMany(3);  // before the call: not recorded
  const fs::path dir = testing::scratchDir("record_rpc") / "out";
  v1::RecordRequest request;
  request.set_dir(dir.string());
  request.set_seconds(0.6);
  auto context = clientContext();
  auto reader = srv.stub().Record(context.get(), request);
  // The first progress message comes once the recording listens for frames.
  v1::RecordProgress message;
  ASSERT_TRUE(reader->Read(&message));
  EXPECT_FALSE(message.done());
  EXPECT_EQ(message.dir(), dir.string());
  // Stamps with sub-microsecond parts: the recording keeps them to the microsecond.
  const TimestampNs first = kServerT0 + 10 * kFramePeriodNs + 123'456;
  for (int i = 0; i < 5; ++i) srv.add(first + i * kFramePeriodNs, /*with_rgb=*/i != 2);
  std::vector<v1::RecordProgress> progress{message};
  while (reader->Read(&message)) progress.push_back(message);
  const grpc::Status status = reader->Finish();
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(progress.back().done());
  EXPECT_EQ(progress.back().frames_written(), 5u);
  EXPECT_EQ(progress.back().frames_dropped(), 0u);
  EXPECT_GE(progress.back().seconds(), 0.6);
  for (std::size_t i = 0; i + 1 < progress.size(); ++i) EXPECT_FALSE(progress[i].done());

  EXPECT_TRUE(fs::exists(dir / "camera.json"));
  const auto replayed = replayAll(dir);
  ASSERT_EQ(replayed.size(), 5u);
  for (std::size_t i = 0; i < replayed.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    expectSameFrame(replayed[i], *srv.added()[3 + i], srv.added()[3]->intrinsics);
  }
}

TEST(Record, RejectsBadDirectoriesAndDurations) {
  TestServer srv(4);
  const fs::path scratch = testing::scratchDir("record_rpc_bad");
  const auto expectStatus = [&](const std::string& dir, double seconds, grpc::StatusCode code,
                                const std::string& text) {
    const grpc::Status status = recordOnce(srv, dir, seconds);
    EXPECT_EQ(status.error_code(), code) << dir << " " << seconds << ": " << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr(text));
  };
  expectStatus("", 1, grpc::StatusCode::INVALID_ARGUMENT, "dir is empty");
  expectStatus("relative/dir", 1, grpc::StatusCode::INVALID_ARGUMENT, "absolute path");
  expectStatus((scratch / "a").string(), 0, grpc::StatusCode::INVALID_ARGUMENT, "seconds must be");
  expectStatus((scratch / "a").string(), -2, grpc::StatusCode::INVALID_ARGUMENT, "seconds must be");
  expectStatus((scratch / "a").string(), 1e6, grpc::StatusCode::INVALID_ARGUMENT,
               "seconds must be");
  EXPECT_FALSE(fs::exists(scratch / "a"));

  fs::create_directories(scratch / "full");
  std::ofstream(scratch / "full" / "keep.txt") << "x";
  expectStatus((scratch / "full").string(), 1, grpc::StatusCode::FAILED_PRECONDITION,
               "is not empty");
  std::ofstream(scratch / "file") << "x";
  expectStatus((scratch / "file").string(), 1, grpc::StatusCode::FAILED_PRECONDITION,
               "not a directory");
}

TEST(Record, RefusesWhenTheSourceHasEnded) {
  TestServer srv(4, [] {
    PipelineStatus s;
    s.source = "tum:/data/desk";
    s.state = SourceState::kEnded;
    return s;
  });
  const fs::path dir = testing::scratchDir("record_rpc_ended") / "out";
  const grpc::Status status = recordOnce(srv, dir.string(), 1);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_THAT(status.error_message(), HasSubstr("tum:/data/desk is ended"));
  EXPECT_FALSE(fs::exists(dir));
}

TEST(Record, OneRecordingAtATime) {
  TestServer srv(4);
  const fs::path scratch = testing::scratchDir("record_rpc_busy");
  v1::RecordRequest request;
  request.set_dir((scratch / "first").string());
  request.set_seconds(0.4);
  auto context = clientContext();
  auto reader = srv.stub().Record(context.get(), request);
  v1::RecordProgress message;
  ASSERT_TRUE(reader->Read(&message));  // the first one is running

  const grpc::Status second = recordOnce(srv, (scratch / "second").string(), 0.1);
  EXPECT_EQ(second.error_code(), grpc::StatusCode::ABORTED) << second.error_message();
  EXPECT_THAT(second.error_message(), HasSubstr("another recording is running"));

  srv.add(kServerT0);
  while (reader->Read(&message)) {
  }
  ASSERT_TRUE(reader->Finish().ok());
  EXPECT_EQ(message.frames_written(), 1u);
  // Once it is done, the next one may start.
  std::vector<v1::RecordProgress> progress;
  const grpc::Status third = recordOnce(srv, (scratch / "third").string(), 0.1, &progress);
  EXPECT_TRUE(third.ok()) << third.error_message();
  ASSERT_FALSE(progress.empty());
  EXPECT_TRUE(progress.back().done());
  EXPECT_EQ(progress.back().frames_written(), 0u);
}

}  // namespace
}  // namespace shapesense
