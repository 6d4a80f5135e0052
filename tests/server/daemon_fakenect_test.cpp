// The daemon on the real libfreenect code path: `--source freenect` while Debian's fakenect
// library replays a synthetic dump in place of a Kinect (what scripts/shapesensed-fakenect
// does). fakenect replaces libfreenect.so.0.5 for a whole process, so the outer test writes the
// dump and re-executes this binary under fakenect (tests/support/self_exec.h); the inner test
// runs an in-process Daemon and checks over gRPC that the served depth matches the synthetic
// ground truth within the raw-disparity quantisation, and that at the end of the dump the
// status says the sensor is lost (RECONNECTING) while old frames are still served.

#include <dlfcn.h>

#include <libfreenect.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <thread>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "depth_compare.h"
#include "self_exec.h"
#include "server_fixture.h"
#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/server/daemon.h"
#include "synthetic_frames.h"
#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::clientContext;

constexpr int kFrames = 10;
constexpr std::uint64_t kSeed = 5;
constexpr const char* kInnerEnv = "SHAPESENSE_DAEMON_FAKENECT_INNER";

TEST(DaemonFakenect, ServesADumpThroughLibfreenectAndReportsItsEndAsALostSensor) {
  const auto library_dir = testing::fakenectLibraryDir();
  if (!library_dir)
    GTEST_SKIP() << "Debian's fakenect library (package libfreenect0.5) is not installed";
  const fs::path dump = testing::scratchDir("daemon_fakenect_dump");
  const std::vector<Frame> frames = testing::syntheticFrames(kSeed, kFrames);
  writeFakenectDump(dump, frames);
  const auto problems = validateFakenectDump(dump);  // fakenect exit()s on a bad dump
  ASSERT_TRUE(problems.empty()) << problems.front();

  const auto [code, output] = testing::runSelf(
      "DaemonFakenect.Inner*", testing::fakenectEnvironment(*library_dir, dump, kInnerEnv),
      dump.parent_path() / "daemon_fakenect_child.log", 90s);
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("[       OK ] DaemonFakenect.InnerDaemonUnderFakenect"), std::string::npos)
      << output;
  EXPECT_EQ(output.find("SKIPPED"), std::string::npos) << output;
}

v1::GetStatusResponse status(v1::ShapeSense::Stub& stub) {
  v1::GetStatusResponse response;
  auto context = clientContext();
  const grpc::Status s = stub.GetStatus(context.get(), {}, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response;
}

/// Runs only inside the child process started above.
TEST(DaemonFakenect, InnerDaemonUnderFakenect) {
  if (std::getenv(kInnerEnv) == nullptr)
    GTEST_SKIP() << "runs inside ServesADumpThroughLibfreenect...";
  Dl_info info{};
  ASSERT_NE(dladdr(reinterpret_cast<void*>(&freenect_process_events), &info), 0);
  ASSERT_NE(std::string(info.dli_fname).find("fakenect"), std::string::npos) << info.dli_fname;

  DaemonOptions options;
  options.source = "freenect";
  options.listen = "127.0.0.1:0";
  options.detectors.segmentation = std::nullopt;  // the test is about the frame path
  options.detectors.planes = std::nullopt;
  Daemon daemon(options);
  auto stub = v1::ShapeSense::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(daemon.port()), grpc::InsecureChannelCredentials()));

  // All frames arrive, then the end of the dump reads as a lost sensor. The state follows the
  // device at once, the message once the pipeline has read the source's error event: wait for
  // both.
  v1::GetStatusResponse s;
  const auto until = std::chrono::steady_clock::now() + 30s;
  do {
    std::this_thread::sleep_for(20ms);
    s = status(*stub);
  } while ((s.frames_received() < static_cast<std::uint64_t>(kFrames) ||
            s.source_state() != v1::GetStatusResponse::RECONNECTING ||
            s.source_message().find("sensor lost") == std::string::npos) &&
           std::chrono::steady_clock::now() < until);
  EXPECT_EQ(s.source(), "freenect:0");
  ASSERT_EQ(s.source_state(), v1::GetStatusResponse::RECONNECTING) << s.ShortDebugString();
  EXPECT_TRUE(s.source_live());
  EXPECT_FALSE(s.source_connected());
  ASSERT_EQ(s.frames_received(), static_cast<std::uint64_t>(kFrames)) << s.ShortDebugString();
  ASSERT_EQ(s.source_dropped_frames(), 0u) << "sequence numbers no longer match the dump's frames";
  EXPECT_NE(s.source_message().find("sensor lost"), std::string::npos) << s.source_message();

  // The cache keeps serving: every frame, the oldest included, matches the ground truth.
  v1::ListFramesResponse list;
  {
    auto context = clientContext();
    ASSERT_TRUE(stub->ListFrames(context.get(), {}, &list).ok());
  }
  ASSERT_EQ(list.frames_size(), kFrames);
  const std::vector<Frame> frames =
      testing::syntheticFrames(kSeed, kFrames);  // what the dump holds
  for (int i = 0; i < kFrames; ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    if (i > 0) {
      EXPECT_GT(list.frames(i).timestamp_ns(), list.frames(i - 1).timestamp_ns());
    }
    v1::GetFrameRequest request;
    request.set_at_ns(list.frames(i).timestamp_ns());
    v1::GetFrameResponse frame;
    auto context = clientContext();
    const grpc::Status got = stub->GetFrame(context.get(), request, &frame);
    ASSERT_TRUE(got.ok()) << got.error_message();
    EXPECT_EQ(frame.info().sequence(), static_cast<std::uint64_t>(i));
    const std::string& png = frame.depth_png();
    const cv::Mat depth = cv::imdecode(
        cv::Mat(1, static_cast<int>(png.size()), CV_8UC1, const_cast<char*>(png.data())),
        cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth.type(), CV_16UC1);
    ASSERT_EQ(depth.size(), frames[i].depth.size());
    const auto comparison = testing::compareThroughRawDisparity(frames[i].depth, depth);
    EXPECT_GT(comparison.compared, 200'000);
    EXPECT_EQ(comparison.violations, 0);
  }
  daemon.shutdown();
}

}  // namespace
}  // namespace shapesense
