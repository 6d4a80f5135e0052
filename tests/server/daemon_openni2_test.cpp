// The daemon on the OpenNI2 path: `--source openni2:Dummy` (OpenNI2's DummyDevice driver, from
// package libopenni2-0) delivers frames with increasing timestamps through the whole daemon, and
// GetStatus reports a connected live sensor.

#include <chrono>
#include <filesystem>
#include <thread>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>

#include "server_fixture.h"
#include "shapesense/server/daemon.h"

// OpenNI2 and its drivers leak small allocations of their own that no API frees (see
// tests/driver/openni2_dummy_test.cpp); LeakSanitizer reads this hook in sanitizer builds.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libOpenNI2.so\nleak:libDummyDevice.so\nleak:libPS1080.so\nleak:libPSLink.so\nleak:"
         "libOniFile.so\n";
}

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using testing::clientContext;

bool dummyDriverInstalled() {
  for (const char* dir :
       {"/usr/lib/x86_64-linux-gnu/OpenNI2/Drivers", "/usr/lib/aarch64-linux-gnu/OpenNI2/Drivers",
        "/usr/lib/OpenNI2/Drivers"}) {
    if (std::filesystem::exists(std::filesystem::path(dir) / "libDummyDevice.so")) return true;
  }
  return false;
}

TEST(DaemonOpenNI2, DummyDeviceFramesArriveWithIncreasingTimestamps) {
  if (!dummyDriverInstalled())
    GTEST_SKIP() << "OpenNI2 DummyDevice driver not installed (libopenni2-0)";
  DaemonOptions options;
  options.source = "openni2:Dummy";
  options.listen = "127.0.0.1:0";
  options.detectors.segmentation = std::nullopt;
  options.detectors.planes = std::nullopt;
  Daemon daemon(options);
  auto stub = v1::ShapeSense::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(daemon.port()), grpc::InsecureChannelCredentials()));

  constexpr std::uint64_t kWanted = 10;
  v1::GetStatusResponse s;
  const auto until = std::chrono::steady_clock::now() + 10s;
  do {
    std::this_thread::sleep_for(20ms);
    s = {};
    auto context = clientContext();
    ASSERT_TRUE(stub->GetStatus(context.get(), {}, &s).ok());
  } while (s.frames_received() < kWanted && std::chrono::steady_clock::now() < until);
  ASSERT_GE(s.frames_received(), kWanted) << s.ShortDebugString();
  EXPECT_EQ(s.source(), "openni2:Dummy");
  EXPECT_EQ(s.source_state(), v1::GetStatusResponse::STREAMING);
  EXPECT_TRUE(s.source_live());
  EXPECT_TRUE(s.source_connected());
  EXPECT_EQ(s.source_reconnects(), 0u);

  v1::ListFramesResponse list;
  auto context = clientContext();
  ASSERT_TRUE(stub->ListFrames(context.get(), {}, &list).ok());
  ASSERT_GE(list.frames_size(), static_cast<int>(kWanted));
  const auto now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  for (int i = 1; i < list.frames_size(); ++i) {
    EXPECT_GT(list.frames(i).timestamp_ns(), list.frames(i - 1).timestamp_ns()) << i;
    EXPECT_GT(list.frames(i).sequence(), list.frames(i - 1).sequence()) << i;
  }
  // Host-clock capture times of this run.
  EXPECT_LE(list.frames(list.frames_size() - 1).timestamp_ns(), now_ns);
  EXPECT_GT(list.frames(0).timestamp_ns(), now_ns - 30'000'000'000LL);
  EXPECT_EQ(list.frames(0).width(), 320u);
  daemon.shutdown();
}

}  // namespace
}  // namespace shapesense
