// The real libfreenect code path (FreenectSource) under Debian's fakenect library, which
// replays a dump written by FakenectDumpWriter in place of a Kinect.
//
// fakenect replaces libfreenect.so.0.5 for a whole process, so the outer test writes the dump
// and re-executes this test binary with LD_LIBRARY_PATH=<multiarch>/fakenect,
// FAKENECT_PATH=<dump> and a filter selecting the inner test, which skips itself unless
// SHAPESENSE_FAKENECT_INNER is set. The inner test checks the delivered depth against the
// synthetic frames (within the raw quantisation) and that the end of the dump, where
// fakenect's freenect_process_events keeps returning -1, is reported as a lost sensor.

#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/freenect_source.h"

#include <gtest/gtest.h>

#include <dlfcn.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <libfreenect.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>
#include <variant>

#include "depth_compare.h"
#include "self_exec.h"
#include "synthetic_frames.h"
#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using testing::fakenectLibraryDir;
using testing::runSelf;
using namespace std::chrono_literals;

constexpr int kFrames = 12;
constexpr std::uint64_t kSeed = 3;
constexpr const char* kInnerEnv = "SHAPESENSE_FAKENECT_INNER";

TEST(FakenectLibrary, FreenectSourceReplaysADumpAndReportsItsEndAsLoss) {
  const auto library_dir = fakenectLibraryDir();
  if (!library_dir)
    GTEST_SKIP() << "Debian's fakenect library (package libfreenect0.5) is not installed";
  const fs::path dump = testing::scratchDir("fakenect_library_dump");
  const std::vector<Frame> frames = testing::syntheticFrames(kSeed, kFrames);
  // Start just before a wrap of the 32-bit device counter.
  FakenectWriteOptions write_options;
  write_options.first_device_ticks = 0xFFFFFFFFu - 4'000'000u;
  writeFakenectDump(dump, frames, write_options);
  // fakenect exit()s on a bad dump: never hand it one that does not validate.
  const auto problems = validateFakenectDump(dump);
  ASSERT_TRUE(problems.empty()) << problems.front();

  std::string asan = "ASAN_OPTIONS=detect_leaks=0";  // fakenect's own allocations at exit
  if (const char* existing = std::getenv("ASAN_OPTIONS"))
    asan = std::string("ASAN_OPTIONS=") + existing + ":detect_leaks=0";
  const char* ld_path = std::getenv("LD_LIBRARY_PATH");
  const std::vector<std::string> env = {
      std::string(kInnerEnv) + "=1",
      "FAKENECT_PATH=" + dump.string(),
      "LD_LIBRARY_PATH=" + library_dir->string() + (ld_path ? std::string(":") + ld_path : ""),
      asan,
  };
  const auto [code, output] = runSelf("FakenectLibrary.Inner*", env,
                                      dump.parent_path() / "fakenect_library_child.log", 90s);
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("[       OK ] FakenectLibrary.InnerFreenectSourceUnderFakenect"),
            std::string::npos)
      << output;
  EXPECT_EQ(output.find("SKIPPED"), std::string::npos) << output;
}

/// Runs only inside the child process started above.
TEST(FakenectLibrary, InnerFreenectSourceUnderFakenect) {
  if (std::getenv(kInnerEnv) == nullptr)
    GTEST_SKIP() << "runs inside FreenectSourceReplaysADump...";
  // Make sure this process really uses fakenect's libfreenect.
  Dl_info info{};
  ASSERT_NE(dladdr(reinterpret_cast<void*>(&freenect_process_events), &info), 0);
  ASSERT_NE(std::string(info.dli_fname).find("fakenect"), std::string::npos) << info.dli_fname;

  // Rendered before the source opens: fakenect starts replaying at once.
  const std::vector<Frame> frames =
      testing::syntheticFrames(kSeed, kFrames);  // what the dump holds

  FreenectOptions options;
  options.live.frame_timeout = 2s;
  options.live.reopen_interval = 200ms;
  options.live.usb_hotplug = false;     // fakenect is no USB device: it is polled
  options.live.max_queued_frames = 64;  // the test reads more slowly than fakenect replays
  FreenectSource source(options);
  EXPECT_EQ(source.describe(), "freenect:0");

  std::stop_source stop;
  std::jthread watchdog([&stop](std::stop_token cancelled) {
    std::mutex m;
    std::condition_variable_any cv;
    std::unique_lock lock(m);
    if (!cv.wait_for(lock, cancelled, 30s, [] { return false; })) stop.request_stop();
  });

  TimestampNs previous = 0;
  std::vector<double> gaps_ms;
  int without_colour = 0;
  const auto start_host = hostNowNs();
  for (int i = 0; i < kFrames; ++i) {
    SourceEvent event = source.next(stop.get_token());
    ASSERT_TRUE(std::holds_alternative<Frame>(event))
        << "frame " << i << ": "
        << (std::holds_alternative<SourceError>(event) ? std::get<SourceError>(event).message
                                                       : "end");
    const Frame& frame = std::get<Frame>(event);
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(i));
    // Live stamps: host time of this run, 1/30 s apart (fakenect replays at the recorded pace).
    EXPECT_GT(frame.timestamp_ns, previous);
    EXPECT_GE(frame.timestamp_ns, start_host - 1'000'000'000);
    if (i > 0) gaps_ms.push_back((frame.timestamp_ns - previous) / 1e6);
    previous = frame.timestamp_ns;

    const Frame& truth = frames[i];
    ASSERT_EQ(frame.depth.size(), truth.depth.size());
    const auto comparison = testing::compareThroughRawDisparity(truth.depth, frame.depth);
    EXPECT_GT(comparison.compared, 200'000) << "frame " << i;
    EXPECT_EQ(comparison.violations, 0) << "frame " << i;
    // Colour that misses its pairing window (a loaded machine, a sanitizer build) leaves a frame
    // depth-only; colour that comes is the recorded frame's own.
    if (frame.rgb.empty())
      ++without_colour;
    else
      EXPECT_EQ(cv::norm(frame.rgb, truth.rgb, cv::NORM_INF), 0.0) << "frame " << i;
  }
  EXPECT_LT(without_colour, kFrames / 2);

  EXPECT_GE(source.connections(), 1u);
  std::nth_element(gaps_ms.begin(), gaps_ms.begin() + gaps_ms.size() / 2, gaps_ms.end());
  // fakenect paces by the recorded host times but does not count time spent between its 'd' and
  // 'r' entries, so on a busy machine the replay runs somewhat slower than 30 Hz.
  EXPECT_GT(gaps_ms[gaps_ms.size() / 2], 30.0);
  EXPECT_LT(gaps_ms[gaps_ms.size() / 2], 80.0);
  EXPECT_LE(previous, hostNowNs());

  // End of the dump: freenect_process_events returns -1, as for an unplugged Kinect.
  SourceEvent event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  const std::string message = std::get<SourceError>(event).message;
  EXPECT_NE(message.find("freenect:0: sensor lost: freenect_process_events returned -1"),
            std::string::npos)
      << message;
  // It keeps trying to reopen (fakenect reopens, then is at the end again) without crashing.
  SourceEvent again = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(again));
  EXPECT_GE(source.connections(), 2u);
  EXPECT_FALSE(stop.stop_requested()) << "watchdog fired";
}

}  // namespace
}  // namespace shapesense
