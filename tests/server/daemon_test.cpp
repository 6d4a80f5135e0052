// The whole daemon in-process over a small recording in a scratch directory.

#include "shapesense/server/daemon.h"
#include "shapesense/driver/open_source.h"

#include <chrono>
#include <fstream>
#include <future>
#include <thread>

#include <gmock/gmock.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "recording_fixture.h"
#include "server_fixture.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/v1/shapesense.grpc.pb.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using testing::clientContext;
using ::testing::HasSubstr;

std::unique_ptr<v1::ShapeSense::Stub> connect(int port) {
  return v1::ShapeSense::NewStub(
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
}

DaemonOptions optionsFor(const std::filesystem::path& recording, Pacing pacing, bool loop = false) {
  DaemonOptions options;
  options.source = "tum:" + recording.string();
  options.pacing = pacing;
  options.loop = loop;
  options.listen = "127.0.0.1:0";
  return options;
}

v1::GetStatusResponse status(v1::ShapeSense::Stub& stub) {
  v1::GetStatusResponse response;
  auto context = clientContext();
  const grpc::Status s = stub.GetStatus(context.get(), {}, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response;
}

TEST(Daemon, ServesARecordingReplayedAtMaxRateAndKeepsServingAfterItEnds) {
  const auto recording = testing::makeSmallRecording("daemon_recording", 5);
  Daemon daemon(optionsFor(recording, Pacing::kAsFastAsPossible));
  ASSERT_GT(daemon.port(), 0);
  auto stub = connect(daemon.port());

  // The recording ends quickly at max rate; the state says so.
  const auto until = std::chrono::steady_clock::now() + 5s;
  v1::GetStatusResponse s = status(*stub);
  while (s.source_state() != v1::GetStatusResponse::ENDED &&
         std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(5ms);
    s = status(*stub);
  }
  ASSERT_EQ(s.source_state(), v1::GetStatusResponse::ENDED);
  ASSERT_TRUE(daemon.pipeline().waitUntilDrained(5s));
  s = status(*stub);
  EXPECT_EQ(s.frames_received(), 5u);
  EXPECT_EQ(s.frames_processed() + s.frames_skipped(), 5u);
  EXPECT_GE(s.frames_processed(), 1u);
  EXPECT_EQ(s.source_errors(), 0u);
  EXPECT_THAT(s.source(), HasSubstr(recording.string()));
  EXPECT_EQ(s.cache().frames(), 5u);
  EXPECT_EQ(s.cache().oldest_ns(), *parseSecondsToNs(testing::smallRecordingStamp(0)));
  EXPECT_EQ(s.cache().newest_ns(), *parseSecondsToNs(testing::smallRecordingStamp(4)));
  EXPECT_THAT(std::vector<std::string>(s.detectors().begin(), s.detectors().end()),
              ::testing::Contains("depth_stats"));

  // Queries still answer after the end: the frame at the stamp of frame 2 is frame 2, with the
  // recording's depth in millimetres.
  v1::GetFrameRequest request;
  request.set_at_ns(*parseSecondsToNs(testing::smallRecordingStamp(2)));
  v1::GetFrameResponse frame;
  auto context = clientContext();
  const grpc::Status got = stub->GetFrame(context.get(), request, &frame);
  ASSERT_TRUE(got.ok()) << got.error_message();
  EXPECT_EQ(frame.info().sequence(), 2u);
  std::vector<unsigned char> bytes(frame.depth_png().begin(), frame.depth_png().end());
  const cv::Mat depth = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  const cv::Mat expected = testing::patternDepthUnits(8, 6, 2) / 5;
  ASSERT_EQ(depth.type(), CV_16UC1);
  ASSERT_EQ(depth.size(), expected.size());
  EXPECT_EQ(cv::countNonZero(depth != expected), 0);
  EXPECT_TRUE(frame.info().has_rgb());

  v1::ListFramesResponse list;
  auto list_context = clientContext();
  ASSERT_TRUE(stub->ListFrames(list_context.get(), {}, &list).ok());
  EXPECT_EQ(list.frames_size(), 5);

  const auto start = std::chrono::steady_clock::now();
  daemon.shutdown();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);
}

TEST(Daemon, NonexistentRecordingThrowsNamingThePath) {
  const auto missing = testing::scratchDir("daemon_missing") / "no_such_recording";
  try {
    Daemon daemon(optionsFor(missing, Pacing::kAsFastAsPossible));
    FAIL() << "Daemon started over a missing recording";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), HasSubstr(missing.string()));
  }
}

TEST(Daemon, BowlStageRunsByDefaultWithTheShippedModels) {
  const auto recording = testing::makeSmallRecording("daemon_bowls_default", 2);
  Daemon daemon(optionsFor(recording, Pacing::kAsFastAsPossible));
  auto stub = connect(daemon.port());
  const auto detectors = status(*stub).detectors();
  EXPECT_THAT(std::vector<std::string>(detectors.begin(), detectors.end()),
              ::testing::Contains("bowls"));
}

TEST(Daemon, BowlsOnWithMissingOrCorruptModelsIsAStartupErrorNamingTheFolder) {
  const auto scratch = testing::scratchDir("daemon_bowl_models");
  const auto recording = testing::makeSmallRecording("daemon_bowl_models_rec", 2);
  const auto corrupt = scratch / "corrupt";
  std::filesystem::create_directories(corrupt);
  std::ofstream(corrupt / "bowl_top.json") << "{\"view\": \"top\", \"stages\": [";
  for (const auto& models : {scratch / "missing", scratch / "empty", corrupt}) {
    std::filesystem::create_directories(scratch / "empty");
    DaemonOptions options = optionsFor(recording, Pacing::kAsFastAsPossible);
    options.detectors.bowl_models = models;
    try {
      Daemon daemon(options);
      FAIL() << "Daemon started with bowl models " << models;
    } catch (const std::runtime_error& e) {
      EXPECT_THAT(e.what(), HasSubstr(models.string()));
      EXPECT_THAT(e.what(), HasSubstr("--bowls off"));
    }
  }
}

TEST(Daemon, BowlsOffNeedsNoModels) {
  const auto recording = testing::makeSmallRecording("daemon_bowls_off", 2);
  DaemonOptions options = optionsFor(recording, Pacing::kAsFastAsPossible);
  options.detectors.bowls = false;
  options.detectors.bowl_models = testing::scratchDir("daemon_bowls_off_models") / "missing";
  Daemon daemon(options);
  auto stub = connect(daemon.port());
  const auto detectors = status(*stub).detectors();
  EXPECT_THAT(std::vector<std::string>(detectors.begin(), detectors.end()),
              ::testing::Not(::testing::Contains("bowls")));
}

TEST(Daemon, UnknownSourceSpecIsInvalidArgument) {
  for (const char* spec : {"bogus", "bogus:1", "kinect2:", "tum:", "TUM:/data"}) {
    DaemonOptions options;
    options.source = spec;
    options.listen = "127.0.0.1:0";
    EXPECT_THROW(Daemon daemon(options), std::invalid_argument) << spec;
  }
  EXPECT_THROW(openSource("nonsense", Pacing::kRecorded, false), std::invalid_argument);
}

TEST(Daemon, ShutdownWithAnOpenWatchStreamIsPrompt) {
  // Paced and looping, so the source is still streaming when the daemon shuts down.
  const auto recording = testing::makeSmallRecording("daemon_watch", 3);
  Daemon daemon(optionsFor(recording, Pacing::kRecorded, /*loop=*/true));
  auto stub = connect(daemon.port());
  auto context = clientContext(10s);
  auto reader = stub->Watch(context.get(), v1::WatchRequest{});
  v1::FrameSummary summary;
  ASSERT_TRUE(reader->Read(&summary)) << "no summary from a streaming daemon";
  EXPECT_TRUE(summary.info().processed());

  const auto start = std::chrono::steady_clock::now();
  auto done = std::async(std::launch::async, [&] { daemon.shutdown(); });
  ASSERT_EQ(done.wait_for(5s), std::future_status::ready) << "Daemon::shutdown hung";
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);

  auto ended = std::async(std::launch::async, [&] {
    v1::FrameSummary more;
    while (reader->Read(&more)) {
    }
    return reader->Finish();
  });
  ASSERT_EQ(ended.wait_for(3s), std::future_status::ready) << "Watch stream outlived the daemon";
  EXPECT_NE(ended.get().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  daemon.shutdown();  // twice is harmless (the destructor does it again)
}

TEST(Daemon, SecondDaemonOnTheSamePortFails) {
  // Two daemons must not share a port: the second one has to fail to start, naming the address,
  // rather than silently splitting clients between two caches.
  const auto recording = testing::makeSmallRecording("daemon_port", 1);
  Daemon first(optionsFor(recording, Pacing::kAsFastAsPossible));
  DaemonOptions options = optionsFor(recording, Pacing::kAsFastAsPossible);
  options.listen = "127.0.0.1:" + std::to_string(first.port());
  try {
    Daemon second(options);
    FAIL() << "a second daemon started on " << options.listen;
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(options.listen));
  }
}

}  // namespace
}  // namespace shapesense
