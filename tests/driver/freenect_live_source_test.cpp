// LiveSource, the device thread behind FreenectSource and OpenNI2Source, driven by a scripted
// device: waiting for a sensor that is not plugged in, loss (error return and silence),
// reopening, stamping across counter wraps and reconnects, queue overflow and stopping.

#include "scripted_arrivals.h"
#include "shapesense/driver/live_sources_device.h"
#include "source_wait.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>
#include <variant>

namespace shapesense {
namespace {

using namespace std::chrono_literals;

/// What the scripted device does in one session.
struct SessionScript {
  int frames = 5;                 ///< depth images delivered, one per pump, 30 Hz device time
  bool fail_at_end = true;        ///< pump returns an error after the frames (else: silence)
  std::uint32_t first_ticks = 0;  ///< 60 MHz counter of the first frame
  bool colour = false;
};

struct Script {
  std::atomic<int> absent_opens{0};  ///< open() fails this many times first
  std::vector<SessionScript> sessions;
  std::atomic<int> opens{0};
  std::atomic<int> sessions_alive{0};
  std::vector<UsbId> usb_ids;  ///< the connector's usbIds()
};

class ScriptedSession final : public DeviceSession {
 public:
  ScriptedSession(SessionScript script, Script& owner) : script_(script), owner_(owner) {
    ++owner_.sessions_alive;
  }
  ~ScriptedSession() override { --owner_.sessions_alive; }

  std::optional<std::string> pump(std::chrono::milliseconds budget,
                                  const DeviceImageSink& sink) override {
    if (sent_ < script_.frames) {
      std::this_thread::sleep_for(2ms);
      const auto ticks = static_cast<std::uint32_t>(script_.first_ticks + sent_ * 2'000'000u);
      DeviceImage depth{DeviceImage::Kind::kDepth,
                        cv::Mat(4, 4, CV_16UC1, cv::Scalar(1000 + sent_)), ticks, hostNowNs()};
      sink(std::move(depth));
      if (script_.colour) {
        sink(DeviceImage{DeviceImage::Kind::kColour,
                         cv::Mat(4, 4, CV_8UC3, cv::Scalar(sent_, 0, 0)), ticks + 60'000u,
                         hostNowNs()});
      }
      ++sent_;
      return std::nullopt;
    }
    if (script_.fail_at_end) return "scripted failure";
    std::this_thread::sleep_for(budget);
    return std::nullopt;
  }
  CameraIntrinsics intrinsics() const override { return {}; }
  bool hasColour() const override { return script_.colour; }
  std::string name() const override { return "scripted device"; }

 private:
  SessionScript script_;
  Script& owner_;
  int sent_ = 0;
};

class ScriptedConnector final : public DeviceConnector {
 public:
  explicit ScriptedConnector(Script& script) : script_(script) {}
  std::string describe() const override { return "scripted"; }
  DeviceClockParams clockParams() const override { return {}; }
  std::span<const UsbId> usbIds() const override { return script_.usb_ids; }
  std::unique_ptr<DeviceSession> open(std::string& why_not) override {
    const int attempt = script_.opens++;
    if (attempt < script_.absent_opens) {
      why_not = "not plugged in";
      return nullptr;
    }
    const std::size_t index = static_cast<std::size_t>(attempt - script_.absent_opens);
    if (index >= script_.sessions.size()) {
      why_not = "script exhausted";
      return nullptr;
    }
    return std::make_unique<ScriptedSession>(script_.sessions[index], script_);
  }

 private:
  Script& script_;
};

LiveSourceOptions fastOptions() {
  LiveSourceOptions options;
  options.frame_timeout = 300ms;
  options.reopen_interval = 50ms;
  options.pump_budget = 20ms;
  options.max_queued_frames = 64;  // a slow (loaded) test thread must not lose frames
  return options;
}

using testing::nextWithin;

TEST(LiveSource, WaitsForTheSensorThenDeliversLosesAndReopens) {
  Script script;
  script.absent_opens = 3;
  script.sessions = {
      SessionScript{.frames = 5, .fail_at_end = true, .first_ticks = 0xFFFFFFFFu - 5'000'000u},
      SessionScript{.frames = 4, .fail_at_end = true, .first_ticks = 1000}};
  LiveSource source(std::make_unique<ScriptedConnector>(script), fastOptions());
  EXPECT_EQ(source.describe(), "scripted");

  auto first = nextWithin(source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(first));
  const std::string waiting = std::get<SourceError>(first).message;
  EXPECT_NE(waiting.find("not available: not plugged in"), std::string::npos) << waiting;
  EXPECT_NE(waiting.find("waiting"), std::string::npos) << waiting;

  TimestampNs previous = 0;
  std::uint64_t expected_sequence = 0;
  auto expectFrames = [&](int count, int first_value) {
    for (int i = 0; i < count; ++i) {
      auto event = nextWithin(source, 2s);
      ASSERT_TRUE(std::holds_alternative<Frame>(event)) << "frame " << i;
      const Frame& frame = std::get<Frame>(event);
      EXPECT_EQ(frame.sequence, expected_sequence++);
      EXPECT_GT(frame.timestamp_ns, previous);
      EXPECT_EQ(frame.depth.at<std::uint16_t>(0, 0), first_value + i);
      previous = frame.timestamp_ns;
    }
  };
  expectFrames(5, 1000);  // across a counter wrap (after frame 2)
  EXPECT_EQ(source.connections(), 1u);

  auto lost = nextWithin(source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(lost));
  const std::string message = std::get<SourceError>(lost).message;
  EXPECT_NE(message.find("scripted: sensor lost: scripted failure; reopening every 50 ms"),
            std::string::npos)
      << message;
  EXPECT_EQ(source.lastError(), message);

  expectFrames(4, 1000);  // the second session, stamped after the first
  EXPECT_EQ(source.connections(), 2u);
  auto lost_again = nextWithin(source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(lost_again));
  // The script is exhausted now: the sensor is "absent" and reported once.
  auto absent = nextWithin(source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(absent));
  EXPECT_NE(std::get<SourceError>(absent).message.find("script exhausted"), std::string::npos);
  EXPECT_FALSE(source.connected());
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(nextWithin(source, 200ms)));  // nothing more
  EXPECT_EQ(script.sessions_alive, 0);
}

TEST(LiveSource, SilenceCountsAsLoss) {
  Script script;
  script.sessions = {SessionScript{.frames = 2, .fail_at_end = false}};
  LiveSource source(std::make_unique<ScriptedConnector>(script), fastOptions());
  EXPECT_TRUE(std::holds_alternative<Frame>(nextWithin(source, 2s)));
  EXPECT_TRUE(std::holds_alternative<Frame>(nextWithin(source, 2s)));
  EXPECT_TRUE(source.connected());
  const auto start = std::chrono::steady_clock::now();
  auto event = nextWithin(source, 3s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_NE(std::get<SourceError>(event).message.find("no depth frame for 3"), std::string::npos)
      << std::get<SourceError>(event).message;
  EXPECT_GE(std::chrono::steady_clock::now() - start, 250ms);
}

TEST(LiveSource, PairsColourAndMapsTime) {
  Script script;
  script.sessions = {SessionScript{.frames = 6, .fail_at_end = true, .colour = true}};
  LiveSource source(std::make_unique<ScriptedConnector>(script), fastOptions());
  int with_colour = 0;
  for (int i = 0; i < 6; ++i) {
    auto event = nextWithin(source, 2s);
    ASSERT_TRUE(std::holds_alternative<Frame>(event)) << i;
    const Frame& frame = std::get<Frame>(event);
    if (!frame.rgb.empty()) {
      ++with_colour;
      EXPECT_EQ(frame.rgb.at<cv::Vec3b>(0, 0)[0], i);  // its own colour image (1 ms later)
    }
  }
  EXPECT_EQ(with_colour, 6);
}

TEST(LiveSource, DropsTheOldestFramesWhenNobodyReads) {
  Script script;
  script.sessions = {SessionScript{.frames = 10, .fail_at_end = false}};
  auto options = fastOptions();
  options.max_queued_frames = 4;
  LiveSource source(std::make_unique<ScriptedConnector>(script), options);
  // All 10 delivered (20 ms of device time), 4 kept.
  const auto deadline = std::chrono::steady_clock::now() + 3s;
  while (source.droppedFrames() < 6 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_EQ(source.droppedFrames(), 6u);
  for (int i = 0; i < 4; ++i) {
    auto event = nextWithin(source, 1s);
    ASSERT_TRUE(std::holds_alternative<Frame>(event));
    EXPECT_EQ(std::get<Frame>(event).sequence, static_cast<std::uint64_t>(i));  // no gaps
    EXPECT_EQ(std::get<Frame>(event).depth.at<std::uint16_t>(0, 0), 1006 + i);  // the newest
  }
}

TEST(LiveSource, StopsPromptlyWhileWaitingForTheSensor) {
  Script script;
  script.absent_opens = 1'000'000;
  auto options = fastOptions();
  options.reopen_interval = 10s;
  auto source = std::make_unique<LiveSource>(std::make_unique<ScriptedConnector>(script), options);
  std::stop_source stop;
  EXPECT_TRUE(std::holds_alternative<SourceError>(source->next(stop.get_token())));
  stop.request_stop();
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source->next(stop.get_token())));
  const auto start = std::chrono::steady_clock::now();
  source.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
}

TEST(LiveSource, AnAbsentSensorIsReopenedWhenItIsPluggedIn) {
  Script script;
  script.absent_opens = 1;
  script.sessions = {SessionScript{.frames = 2, .fail_at_end = false}};
  script.usb_ids.assign(kKinectUsbIds.begin(), kKinectUsbIds.end());
  auto arrivals = std::make_shared<testing::ScriptedArrivals>(true);
  LiveSourceOptions options = fastOptions();
  options.usb_arrivals = arrivals;
  options.hotplug_poll_interval = std::chrono::hours(1);  // only an arrival can reopen it
  LiveSource source(std::make_unique<ScriptedConnector>(script), options);
  EXPECT_TRUE(source.hotplug());

  auto absent = nextWithin(source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(absent));
  EXPECT_NE(std::get<SourceError>(absent).message.find("when it is plugged in (USB hotplug)"),
            std::string::npos)
      << std::get<SourceError>(absent).message;
  arrivals->plugIn({0x046d, 0xc52b});  // another device: the wait goes on
  arrivals->plugIn({0x045e, 0x02ae});  // the Kinect's camera
  ASSERT_TRUE(std::holds_alternative<Frame>(nextWithin(source, 5s)));
  EXPECT_EQ(script.opens, 2);
  EXPECT_EQ(source.connections(), 1u);
}

TEST(LiveSource, WithoutHotplugTheSensorIsPolled) {
  Script script;
  script.absent_opens = 2;
  script.sessions = {SessionScript{.frames = 2, .fail_at_end = false}};
  script.usb_ids.assign(kKinectUsbIds.begin(), kKinectUsbIds.end());
  LiveSourceOptions options = fastOptions();
  options.usb_arrivals = std::make_shared<testing::ScriptedArrivals>(false);
  options.hotplug_poll_interval = std::chrono::hours(1);  // not used without hotplug
  LiveSource source(std::make_unique<ScriptedConnector>(script), options);
  EXPECT_FALSE(source.hotplug());
  auto absent = nextWithin(source, 2s);
  ASSERT_TRUE(std::holds_alternative<SourceError>(absent));
  EXPECT_NE(std::get<SourceError>(absent).message.find("retrying every 50 ms"), std::string::npos)
      << std::get<SourceError>(absent).message;
  ASSERT_TRUE(std::holds_alternative<Frame>(nextWithin(source, 5s)));
  EXPECT_EQ(script.opens, 3);
}

TEST(LiveSource, CountsLosses) {
  Script script;
  script.sessions = {SessionScript{.frames = 1}, SessionScript{.frames = 1}};
  LiveSource source(std::make_unique<ScriptedConnector>(script), fastOptions());
  for (int event = 0; event < 4; ++event) nextWithin(source, 2s);  // frame, loss, frame, loss
  const SourceHealth health = source.health();
  EXPECT_EQ(health.disconnects, 2u);
  EXPECT_EQ(health.reconnects, 1u);
}

}  // namespace
}  // namespace shapesense
