// FreenectSource with the real libfreenect and no Kinect plugged in (it waits and says so),
// device selectors, and the openLiveSource factory behind the daemon's --source specs.

#include "shapesense/driver/freenect_source.h"
#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/live_sources.h"
#include "shapesense/driver/openni2_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <variant>

#include "test_paths.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;

TEST(FreenectDeviceSelector, IndexOrSerial) {
  EXPECT_EQ(FreenectDeviceSelector::parse("").index, 0);
  EXPECT_TRUE(FreenectDeviceSelector::parse("").serial.empty());
  EXPECT_EQ(FreenectDeviceSelector::parse("2").index, 2);
  EXPECT_EQ(FreenectDeviceSelector::parse("12").index, 12);
  const auto serial = FreenectDeviceSelector::parse("A00364A11700045A");
  EXPECT_EQ(serial.serial, "A00364A11700045A");
  EXPECT_EQ(serial.toString(), "A00364A11700045A");
  // Kinect for Windows serials can be all digits; more than three digits is a serial.
  EXPECT_EQ(FreenectDeviceSelector::parse("0000000000000000").serial, "0000000000000000");
  EXPECT_EQ(FreenectDeviceSelector::parse("1").toString(), "1");
}

TEST(FreenectSource, WithoutAKinectItWaitsAndSaysSo) {
  FreenectOptions options;
  options.device = FreenectDeviceSelector::parse("7");
  options.live.reopen_interval = 100ms;
  auto source = std::make_unique<FreenectSource>(options);
  EXPECT_EQ(source->describe(), "freenect:7");
  std::stop_source stop;
  std::jthread watchdog([&stop](std::stop_token cancelled) {
    std::mutex m;
    std::condition_variable_any cv;
    std::unique_lock lock(m);
    if (!cv.wait_for(lock, cancelled, 5s, [] { return false; })) stop.request_stop();
  });
  auto event = source->next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event)) << "a Kinect #7 is connected?";
  const std::string message = std::get<SourceError>(event).message;
  EXPECT_NE(message.find("freenect:7: sensor not available: "), std::string::npos) << message;
  EXPECT_NE(message.find("waiting for it"), std::string::npos) << message;
  EXPECT_FALSE(source->connected());
  EXPECT_EQ(source->connections(), 0u);
  EXPECT_EQ(source->lastError(), message);
  const auto start = std::chrono::steady_clock::now();
  source.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
}

TEST(OpenLiveSource, KnowsItsKindsOnly) {
  EXPECT_EQ(openLiveSource("tum", "/tmp"), nullptr);
  EXPECT_EQ(openLiveSource("synthetic", ""), nullptr);
  EXPECT_THROW(openLiveSource("fakenect", ""), std::invalid_argument);
  EXPECT_THROW(openLiveSource("fakenect", "/nonexistent/dump"), std::runtime_error);

  auto freenect = openLiveSource("freenect", "A00364A11700045A");
  ASSERT_NE(freenect, nullptr);
  EXPECT_EQ(freenect->describe(), "freenect:A00364A11700045A");
  EXPECT_NE(dynamic_cast<FreenectSource*>(freenect.get()), nullptr);
  EXPECT_EQ(openLiveSource("freenect", "")->describe(), "freenect:0");

  auto openni2 = openLiveSource("openni2", "");
  ASSERT_NE(openni2, nullptr);
  EXPECT_EQ(openni2->describe(), "openni2");
  EXPECT_NE(dynamic_cast<OpenNI2Source*>(openni2.get()), nullptr);

  const auto dir = testing::scratchDir("open_live_source_fakenect");
  Frame frame;
  frame.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(1500));
  frame.timestamp_ns = 1'700'000'000'000'000'000;
  FakenectDumpWriter(dir).write(frame);
  auto fakenect = openLiveSource("fakenect", dir.string());
  ASSERT_NE(fakenect, nullptr);
  EXPECT_EQ(fakenect->describe(), "fakenect:" + dir.string());
  std::stop_source stop;
  auto event = fakenect->next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<Frame>(event));
  EXPECT_NEAR(std::get<Frame>(event).depth.at<std::uint16_t>(100, 100), 1500, 4);
}

}  // namespace
}  // namespace shapesense
