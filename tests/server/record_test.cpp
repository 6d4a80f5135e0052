// Record through a real in-process gRPC server: the frames delivered during the call are
// written under the recordings root in the TUM layout and replay bit-identically (depth, RGB,
// stamps to the microsecond, intrinsics); bad requests get the documented statuses; names that
// would lead out of the root write nothing anywhere; a recording stops before the disk fills.

#include <fcntl.h>
#include <linux/fs.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <future>
#include <thread>
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
  const fs::path dir = fs::canonical(srv.recordRoot()) / "out";
  v1::RecordRequest request;
  request.set_dir("out");
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
  const fs::path root = srv.recordRoot();
  const auto expectStatus = [&](const std::string& dir, double seconds, grpc::StatusCode code,
                                const std::string& text) {
    const grpc::Status status = recordOnce(srv, dir, seconds);
    EXPECT_EQ(status.error_code(), code) << dir << " " << seconds << ": " << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr(text));
  };
  expectStatus("", 1, grpc::StatusCode::INVALID_ARGUMENT, "dir is empty");
  expectStatus(".", 1, grpc::StatusCode::INVALID_ARGUMENT, "the recordings root itself");
  expectStatus("a", 0, grpc::StatusCode::INVALID_ARGUMENT, "seconds must be");
  expectStatus("a", -2, grpc::StatusCode::INVALID_ARGUMENT, "seconds must be");
  // The default cap is 600 s (shapesensed --record-max-seconds).
  expectStatus("a", 601, grpc::StatusCode::INVALID_ARGUMENT, "at most 600");
  expectStatus("a", 86400, grpc::StatusCode::INVALID_ARGUMENT, "--record-max-seconds");
  EXPECT_FALSE(fs::exists(root / "a"));

  fs::create_directories(root / "full");
  std::ofstream(root / "full" / "keep.txt") << "x";
  expectStatus("full", 1, grpc::StatusCode::FAILED_PRECONDITION, "is not empty");
  std::ofstream(root / "file") << "x";
  expectStatus("file", 1, grpc::StatusCode::FAILED_PRECONDITION, "not a directory");
  expectStatus("file/sub", 1, grpc::StatusCode::FAILED_PRECONDITION, "not a directory");
}

/// Every regular file and directory under `dir`, as paths relative to it.
std::vector<std::string> contents(const fs::path& dir) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    found.push_back(entry.path().lexically_relative(dir).string());
  }
  std::sort(found.begin(), found.end());
  return found;
}

TEST(Record, RefusesNamesThatLeadOutOfTheRecordingsRootAndWritesNothingOutside) {
  // scratch/root is the recordings root; scratch/outside a directory beside it that a
  // symbolic link in the root points to.
  const fs::path scratch = testing::scratchDir("record_rpc_escape");
  RecordLimits limits;
  limits.root = scratch / "root";
  fs::create_directories(limits.root);
  fs::create_directories(scratch / "outside");
  fs::create_directory_symlink(scratch / "outside", limits.root / "out-link");
  fs::create_directory_symlink("/", limits.root / "slash");
  TestServer srv(4, {}, limits);
  const auto expectRefused = [&](const std::string& dir, grpc::StatusCode code,
                                 const std::string& text) {
    const grpc::Status status = recordOnce(srv, dir, 0.2);
    EXPECT_EQ(status.error_code(), code) << dir << ": " << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr(text)) << dir;
  };
  // The request that wrote into /root before: an absolute path, `..` or not.
  expectRefused("/tmp/../root/x", grpc::StatusCode::INVALID_ARGUMENT, "is absolute");
  expectRefused((scratch / "tmp" / ".." / "escaped").string(), grpc::StatusCode::INVALID_ARGUMENT,
                "is absolute");
  // Absolute is refused even inside the root: a name is relative to it.
  expectRefused((limits.root / "inside").string(), grpc::StatusCode::INVALID_ARGUMENT,
                "is absolute");
  expectRefused("../escaped", grpc::StatusCode::INVALID_ARGUMENT, "contains '..'");
  expectRefused("a/../../escaped", grpc::StatusCode::INVALID_ARGUMENT, "contains '..'");
  expectRefused("a/b/../../../escaped", grpc::StatusCode::INVALID_ARGUMENT, "contains '..'");
  expectRefused("out-link", grpc::StatusCode::PERMISSION_DENIED,
                "leads out of the recordings root");
  expectRefused("out-link/new/deeper", grpc::StatusCode::PERMISSION_DENIED,
                "leads out of the recordings root");
  expectRefused("slash/tmp/escaped", grpc::StatusCode::PERMISSION_DENIED,
                "leads out of the recordings root");

  EXPECT_THAT(contents(scratch / "outside"), ::testing::IsEmpty());
  EXPECT_THAT(contents(scratch),
              ::testing::ElementsAre("outside", "root", "root/out-link", "root/slash"));
  EXPECT_FALSE(fs::exists("/tmp/escaped"));
}

/// Makes a directory unwritable for the daemon's user while it lives: immutable (mkdir in it
/// fails with EPERM, even for root) where the file system and capabilities allow, else mode
/// 0555 (EACCES, for users other than root). locked() is false when neither works.
class UnwritableDir {
 public:
  explicit UnwritableDir(fs::path dir) : dir_(std::move(dir)) {
    if (setImmutable(true)) {
      how_ = How::kImmutable;
    } else if (::geteuid() != 0 && ::chmod(dir_.c_str(), 0555) == 0) {
      how_ = How::kMode;
    }
  }
  ~UnwritableDir() {
    if (how_ == How::kImmutable) setImmutable(false);
    if (how_ == How::kMode) ::chmod(dir_.c_str(), 0755);
  }
  bool locked() const { return how_ != How::kNone; }

 private:
  enum class How { kNone, kImmutable, kMode };
  bool setImmutable(bool on) {
    const int fd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY);
    if (fd < 0) return false;
    int flags = 0;
    bool done = ::ioctl(fd, FS_IOC_GETFLAGS, &flags) == 0;
    if (done) {
      flags = on ? flags | FS_IMMUTABLE_FL : flags & ~FS_IMMUTABLE_FL;
      done = ::ioctl(fd, FS_IOC_SETFLAGS, &flags) == 0;
    }
    ::close(fd);
    return done;
  }
  fs::path dir_;
  How how_ = How::kNone;
};

TEST(Record, DirectoriesTheDaemonMayNotWriteArePermissionDenied) {
  const fs::path scratch = testing::scratchDir("record_rpc_not_permitted");
  RecordLimits limits;
  limits.root = scratch / "root";
  fs::create_directories(limits.root / "frozen");
  fs::create_directories(limits.root / "open");
  fs::create_directories(limits.root / "open" / "frozen-inside");
  TestServer srv(4, {}, limits);
  {
    // A new directory under an unwritable one, and an existing empty one the daemon cannot
    // write into (which used to be accepted and then fail at the first frame, or never).
    UnwritableDir frozen(limits.root / "frozen");
    UnwritableDir frozen_inside(limits.root / "open" / "frozen-inside");
    if (!frozen.locked() || !frozen_inside.locked())
      GTEST_SKIP() << "cannot make a directory unwritable here (root without FS_IMMUTABLE_FL)";
    for (const std::string name : {"frozen/take-1", "open/frozen-inside"}) {
      const grpc::Status status = recordOnce(srv, name, 0.2);
      EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED)
          << name << ": " << status.error_message();
      EXPECT_THAT(status.error_message(), HasSubstr("the daemon may not")) << name;
      EXPECT_THAT(status.error_message(), HasSubstr("--record-root")) << name;
    }
  }
  EXPECT_FALSE(fs::exists(limits.root / "frozen" / "take-1"));
  EXPECT_TRUE(fs::is_empty(limits.root / "open" / "frozen-inside"));
}

/// Records into `name` while one frame is added; the frames written, or -1 on an error status.
int recordOneFrame(TestServer& srv, const std::string& name) {
  v1::RecordRequest request;
  request.set_dir(name);
  request.set_seconds(0.3);
  auto context = clientContext();
  auto reader = srv.stub().Record(context.get(), request);
  v1::RecordProgress message;
  if (!reader->Read(&message)) return -1;  // the first one comes once it listens for frames
  srv.add(kServerT0 + static_cast<TimestampNs>(srv.added().size()) * kFramePeriodNs);
  while (reader->Read(&message)) {
  }
  const grpc::Status status = reader->Finish();
  EXPECT_TRUE(status.ok()) << name << ": " << status.error_message();
  return status.ok() ? static_cast<int>(message.frames_written()) : -1;
}

TEST(Record, FollowsSymbolicLinksThatStayInsideTheRootAndCreatesNestedNames) {
  TestServer srv(4);
  fs::create_directories(srv.recordRoot() / "real");
  fs::create_directory_symlink(srv.recordRoot() / "real", srv.recordRoot() / "alias");
  EXPECT_EQ(recordOneFrame(srv, "alias/take-1"), 1);
  EXPECT_EQ(recordOneFrame(srv, "desk/2026/take-1"), 1);
  EXPECT_TRUE(fs::exists(srv.recordRoot() / "real" / "take-1" / "camera.json"));
  EXPECT_TRUE(fs::exists(srv.recordRoot() / "desk" / "2026" / "take-1" / "camera.json"));
}

/// Free space the next RecordLimits::free_bytes call reports.
std::atomic<std::uintmax_t> reported_free{0};
std::uintmax_t reportedFree(const fs::path&) { return reported_free; }

TEST(Record, DoesNotStartBelowTheFreeSpaceFloor) {
  RecordLimits limits;
  limits.min_free_bytes = 100ull << 20;
  limits.free_bytes = &reportedFree;
  reported_free = 99ull << 20;
  TestServer srv(4, {}, limits);
  const grpc::Status status = recordOnce(srv, "take", 1);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_THAT(status.error_message(), HasSubstr("99 MB free, below the floor of 100 MB"));
  EXPECT_FALSE(fs::exists(srv.recordRoot() / "take"));
}

TEST(Record, StopsWithAValidRecordingWhenFreeSpaceFallsBelowTheFloor) {
  RecordLimits limits;
  limits.min_free_bytes = 100ull << 20;
  limits.free_bytes = &reportedFree;
  reported_free = 5000ull << 20;
  TestServer srv(64, {}, limits);
  v1::RecordRequest request;
  request.set_dir("take");
  request.set_seconds(60);
  auto context = clientContext(std::chrono::milliseconds(30000));
  auto reader = srv.stub().Record(context.get(), request);
  v1::RecordProgress message;
  ASSERT_TRUE(reader->Read(&message));
  for (int i = 0; i < 3; ++i) srv.add(kServerT0 + i * kFramePeriodNs);
  // Frames written with room to spare, then the disk fills up: the next check stops it.
  while (message.frames_written() < 3 && reader->Read(&message)) {
  }
  ASSERT_EQ(message.frames_written(), 3u);
  reported_free = 50ull << 20;
  while (reader->Read(&message)) {
  }
  const grpc::Status status = reader->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_THAT(status.error_message(), HasSubstr("recording stopped"));
  EXPECT_THAT(status.error_message(), HasSubstr("3 frame(s) written"));
  const auto replayed = replayAll(srv.recordRoot() / "take");
  ASSERT_EQ(replayed.size(), 3u);
  expectSameFrame(replayed[2], *srv.added()[2], srv.added()[0]->intrinsics);
}

TEST(Record, RefusesWhenTheSourceHasEnded) {
  TestServer srv(4, [] {
    PipelineStatus s;
    s.source = "tum:/data/desk";
    s.state = SourceState::kEnded;
    return s;
  });
  const fs::path dir = srv.recordRoot() / "out";
  const grpc::Status status = recordOnce(srv, "out", 1);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_THAT(status.error_message(), HasSubstr("tum:/data/desk is ended"));
  EXPECT_FALSE(fs::exists(dir));
}

TEST(Record, OneRecordingAtATime) {
  TestServer srv(4);
  v1::RecordRequest request;
  request.set_dir("first");
  request.set_seconds(0.4);
  auto context = clientContext();
  auto reader = srv.stub().Record(context.get(), request);
  v1::RecordProgress message;
  ASSERT_TRUE(reader->Read(&message));  // the first one is running

  const grpc::Status second = recordOnce(srv, "second", 0.1);
  EXPECT_EQ(second.error_code(), grpc::StatusCode::ABORTED) << second.error_message();
  EXPECT_THAT(second.error_message(), HasSubstr("another recording is running"));

  srv.add(kServerT0);
  while (reader->Read(&message)) {
  }
  ASSERT_TRUE(reader->Finish().ok());
  EXPECT_EQ(message.frames_written(), 1u);
  // Once it is done, the next one may start.
  std::vector<v1::RecordProgress> progress;
  const grpc::Status third = recordOnce(srv, "third", 0.1, &progress);
  EXPECT_TRUE(third.ok()) << third.error_message();
  ASSERT_FALSE(progress.empty());
  EXPECT_TRUE(progress.back().done());
  EXPECT_EQ(progress.back().frames_written(), 0u);
}

}  // namespace
}  // namespace shapesense
