// The watchdog's question, asked of a real Pipeline: a source that delivers nothing or a
// detector stuck on one frame is a hang once the stall limit has passed; an ended recording or
// a sensor being reconnected is idle on purpose. Times are judged at chosen instants relative
// to the pipeline's own progress stamps, so no test depends on how fast this machine is.

#include "shapesense/server/pipeline_health.h"

#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <condition_variable>
#include <cstdio>
#include <mutex>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "recording_fixture.h"
#include "server_fixture.h"
#include "shapesense/server/daemon.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr auto kStallLimit = std::chrono::steady_clock::duration(10s);

/// Opens and closes a gate; waiters pass one at a time per open() call.
class Gate {
 public:
  void open(int passes = 1) {
    {
      std::lock_guard lock(mutex_);
      passes_ += passes;
    }
    cv_.notify_all();
  }
  /// False when `stop` was requested first.
  bool pass(std::stop_token stop) {
    std::unique_lock lock(mutex_);
    if (!cv_.wait(lock, stop, [this] { return passes_ > 0; })) return false;
    --passes_;
    return true;
  }

 private:
  std::mutex mutex_;
  std::condition_variable_any cv_;
  int passes_ = 0;
};

/// Delivers a frame each time its gate opens; ends after `frames` when `ends` is set.
class GatedSource : public FrameSource {
 public:
  GatedSource(Gate& gate, SourceHealth health = {}, int frames = 1000, bool ends = false)
      : gate_(gate), health_(health), frames_(frames), ends_(ends) {}
  std::string describe() const override { return "fake:gated"; }
  SourceHealth health() const override { return health_; }
  SourceEvent next(std::stop_token stop) override {
    if (sent_ == frames_ && ends_) return EndOfStream{};
    if (!gate_.pass(stop)) return EndOfStream{};
    const int index = sent_++;
    return testing::makeTestFrame(testing::kServerT0 + index * testing::kFramePeriodNs,
                                  static_cast<std::uint64_t>(index));
  }

 private:
  Gate& gate_;
  SourceHealth health_;
  int frames_;
  bool ends_;
  int sent_ = 0;
};

/// Holds the detector thread on each frame until its gate opens.
class GatedStage : public DetectorStage {
 public:
  explicit GatedStage(Gate& gate) : gate_(gate) {}
  std::string name() const override { return "gated"; }
  void run(const Frame&, FrameResults&) override { gate_.pass(std::stop_token{}); }

 private:
  Gate& gate_;
};

struct Harness {
  FrameCache cache{16};
  SummaryHub hub;
  Gate source_gate;
  Gate stage_gate;
  std::unique_ptr<Pipeline> pipeline;

  explicit Harness(std::unique_ptr<FrameSource> source, bool gated_stage = false) {
    DetectorChain chain;
    if (gated_stage) chain.add(std::make_unique<GatedStage>(stage_gate));
    pipeline = std::make_unique<Pipeline>(std::move(source), std::move(chain), cache, hub);
  }
  ~Harness() {
    stage_gate.open(1000);  // let a held detector thread finish so stop() can join it
    pipeline->stop();
  }
};

TEST(PipelineHealth, ASourceThatDeliversNothingHangsOnceTheStallLimitPasses) {
  Gate gate;
  Harness h(std::make_unique<GatedSource>(gate));
  h.pipeline->start();
  const PipelineProgress progress = h.pipeline->progress();
  EXPECT_EQ(progress.state, SourceState::kStreaming);
  EXPECT_TRUE(judgePipelineHealth(progress, progress.last_source_event + 9s, kStallLimit).healthy);
  const HealthVerdict hung =
      judgePipelineHealth(progress, progress.last_source_event + 11s, kStallLimit);
  EXPECT_FALSE(hung.healthy);
  EXPECT_THAT(hung.reason, HasSubstr("the source fake:gated has delivered nothing for 11.0 s"));
  gate.open();  // unblocks the capture thread's next() for stop()
}

TEST(PipelineHealth, EveryFrameCountsAsProgress) {
  Gate gate;
  auto source = std::make_unique<GatedSource>(gate);
  Harness h(std::move(source));
  h.pipeline->start();
  const PipelineProgress before = h.pipeline->progress();
  gate.open();
  ASSERT_TRUE(testing::waitFor([&] { return h.pipeline->status().frames_received == 1; }));
  const PipelineProgress after = h.pipeline->progress();
  EXPECT_GT(after.last_source_event, before.last_source_event);
  EXPECT_TRUE(judgePipelineHealth(after, after.last_source_event + 9s, kStallLimit).healthy);
  EXPECT_FALSE(judgePipelineHealth(after, after.last_source_event + 11s, kStallLimit).healthy);
}

TEST(PipelineHealth, ASensorBeingReconnectedIsIdleNotHung) {
  Gate gate;
  SourceHealth lost;
  lost.live = true;
  lost.connected = false;
  Harness h(std::make_unique<GatedSource>(gate, lost));
  h.pipeline->start();
  const PipelineProgress progress = h.pipeline->progress();
  EXPECT_EQ(progress.state, SourceState::kReconnecting);
  EXPECT_TRUE(judgePipelineHealth(progress, progress.last_source_event + 1h, kStallLimit).healthy);
  gate.open();
}

TEST(PipelineHealth, AnEndedRecordingIsIdleNotHung) {
  Gate gate;
  gate.open(2);
  Harness h(std::make_unique<GatedSource>(gate, SourceHealth{}, 2, /*ends=*/true));
  h.pipeline->start();
  ASSERT_TRUE(h.pipeline->waitUntilDrained(5s));
  const PipelineProgress progress = h.pipeline->progress();
  EXPECT_EQ(progress.state, SourceState::kEnded);
  EXPECT_FALSE(progress.detecting_since);
  EXPECT_TRUE(judgePipelineHealth(progress, progress.last_source_event + 1h, kStallLimit).healthy);
}

TEST(PipelineHealth, DetectorsStuckOnOneFrameHang) {
  Gate gate;
  Harness h(std::make_unique<GatedSource>(gate), /*gated_stage=*/true);
  h.pipeline->start();
  gate.open();
  ASSERT_TRUE(testing::waitFor([&] { return h.pipeline->progress().detecting_since.has_value(); }));
  PipelineProgress progress = h.pipeline->progress();
  const auto since = *progress.detecting_since;
  EXPECT_TRUE(judgePipelineHealth(progress, since + 9s, kStallLimit).healthy);
  // Judged 11 s on with a source that kept delivering: only the detectors are stuck.
  progress.last_source_event = since + 11s;
  const HealthVerdict hung = judgePipelineHealth(progress, since + 11s, kStallLimit);
  EXPECT_FALSE(hung.healthy);
  EXPECT_THAT(hung.reason, HasSubstr("the detectors have spent 11.0 s on one frame"));

  h.stage_gate.open();
  ASSERT_TRUE(testing::waitFor([&] { return !h.pipeline->progress().detecting_since; }));
  gate.open();
}

/// A datagram socket standing in for systemd's notify socket.
class NotifySocket {
 public:
  explicit NotifySocket(const std::filesystem::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::snprintf(address.sun_path, sizeof address.sun_path, "%s", path.c_str());
    std::filesystem::remove(path);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("cannot bind " + path.string());
    }
    const timeval timeout{5, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  }
  ~NotifySocket() { ::close(fd_); }
  /// The next message; empty after 5 s without one.
  std::string receive() {
    char buffer[4096];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
  }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// shapesensed as systemd would run it with WatchdogSec=0.2: its notify messages go to a
/// NotifySocket in `dir`. SIGTERM on destruction.
class WatchedDaemon {
 public:
  WatchedDaemon(const std::filesystem::path& dir, std::vector<std::string> arguments)
      : notify_(dir / "notify") {
    const std::string binary = std::string(SHAPESENSE_BINARY_DIR) + "/server/shapesensed";
    arguments.insert(arguments.begin(), binary);
    arguments.push_back("--record-root=" + (dir / "recordings").string());
    arguments.push_back("--object-models=" + (dir / "object-models").string());
    std::vector<char*> argv;
    for (auto& a : arguments) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env = {"NOTIFY_SOCKET=" + (dir / "notify").string(),
                                    "WATCHDOG_USEC=200000"};
    for (char** e = environ; *e; ++e) env.emplace_back(*e);
    std::vector<char*> envp;
    for (auto& e : env) envp.push_back(e.data());
    envp.push_back(nullptr);
    if (::posix_spawn(&pid_, binary.c_str(), nullptr, nullptr, argv.data(), envp.data()) != 0) {
      throw std::runtime_error("cannot run " + binary);
    }
  }
  ~WatchedDaemon() { stop(); }
  /// Sends SIGTERM and returns the exit status.
  int stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, &status_, 0);
      pid_ = 0;
    }
    return status_;
  }
  NotifySocket& notify() { return notify_; }

 private:
  NotifySocket notify_;
  pid_t pid_ = 0;
  int status_ = -1;
};

TEST(PipelineHealth, ShapesensedPetsTheSystemdWatchdogWhileFramesFlow) {
  WatchedDaemon daemon(testing::scratchDir("watchdog"),
                       {"--listen", "127.0.0.1:0", "--bowls", "off"});
  std::vector<std::string> messages;
  for (int i = 0; i < 4; ++i) messages.push_back(daemon.notify().receive());
  const int status = daemon.stop();
  EXPECT_EQ(messages[0], "READY=1");
  // Petted at half of WATCHDOG_USEC while the synthetic scene delivers frames.
  EXPECT_THAT(std::vector<std::string>(messages.begin() + 1, messages.end()),
              ::testing::Each(std::string("WATCHDOG=1")));
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
}

TEST(PipelineHealth, ShapesensedStopsPettingTheWatchdogWhenTheSourceStalls) {
  // Two frames 1000 s apart replayed at the recorded rate: after the first, the source delivers
  // nothing, as a sensor that hangs without disconnecting would.
  const auto dir = testing::scratchDir("watchdog_stall");
  testing::RecordingBuilder recording(dir / "recording");
  for (const char* stamp : {"1600000000.000000", "1600001000.000000"}) {
    recording.addDepth(stamp);
    recording.addRgb(stamp);
  }
  recording.writeCamera();
  recording.finish();
  WatchedDaemon daemon(dir, {"--listen", "127.0.0.1:0", "--bowls", "off", "--source",
                             "tum:" + (dir / "recording").string(), "--rate", "recorded",
                             "--watchdog-stall-seconds", "0.5"});
  ASSERT_EQ(daemon.notify().receive(), "READY=1");
  // Pets while the first frame is recent, then none: receive() gives up after 5 s of silence.
  int pets = 0;
  std::string message;
  while ((message = daemon.notify().receive()) == "WATCHDOG=1") ++pets;
  EXPECT_EQ(message, "");
  EXPECT_GE(pets, 1);
  // The cap on pets is loose: 0.5 s of health at one pet per 0.1 s, whatever the machine's load.
  EXPECT_LE(pets, 20);
}

TEST(PipelineHealth, TheDaemonReportsItsPipelineHealthy) {
  DaemonOptions options;
  options.source = "synthetic";
  options.listen = "127.0.0.1:0";
  options.detectors.bowls = false;
  Daemon daemon(options);
  const HealthVerdict verdict = daemon.health();
  EXPECT_TRUE(verdict.healthy) << verdict.reason;
}

}  // namespace
}  // namespace shapesense
