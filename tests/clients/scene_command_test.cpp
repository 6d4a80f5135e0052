// `shapesense scene` against a real in-process gRPC server whose cache holds frames of the
// synthetic demo scene with the standard chain's results: the table, --json, the preview file,
// and --watch's update lines.

#include <algorithm>
#include <filesystem>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "server_fixture.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "synthetic_frames.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using ::testing::HasSubstr;

std::string runScene(const cli::GlobalOptions& global, std::vector<std::string> args) {
  CLI::App app;
  cli::addSceneCommand(app, global);
  args.insert(args.begin(), "scene");
  std::reverse(args.begin(), args.end());  // CLI11 takes its arguments reversed
  ::testing::internal::CaptureStdout();
  try {
    app.parse(args);
  } catch (...) {
    ::testing::internal::GetCapturedStdout();
    throw;
  }
  return ::testing::internal::GetCapturedStdout();
}

class SceneCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    const DetectorChain chain = makeDetectorChain(DetectorConfig{});
    for (auto& frame : testing::syntheticFrames(1, 6)) {
      auto shared = std::make_shared<const Frame>(std::move(frame));
      ASSERT_TRUE(srv.cache().insert(shared));
      last = std::make_shared<const FrameResults>(chain.process(*shared));
      ASSERT_TRUE(srv.cache().publishResults(shared->sequence, last));
      last_frame = shared;
    }
    global.server = "127.0.0.1:" + std::to_string(srv.port());
  }

  testing::TestServer srv;
  std::shared_ptr<const Frame> last_frame;
  std::shared_ptr<const FrameResults> last;
  cli::GlobalOptions global;
};

TEST_F(SceneCommand, JsonHoldsTheFramesStablePlanesAndThings) {
  const auto json = nlohmann::json::parse(runScene(global, {"--json"}));
  EXPECT_EQ(json["info"]["timestamp_ns"], std::to_string(last_frame->timestamp_ns));
  EXPECT_EQ(json["planes"].size(), last->planes->accumulated.size());
  EXPECT_EQ(json.value("objects", nlohmann::json::array()).size(), last->things->size());
  EXPECT_EQ(json["session_id"].get<std::string>().size(), 32u);
}

TEST_F(SceneCommand, TableListsEachPlaneAndWritesThePreview) {
  const auto out = testing::scratchDir("scene_command") / "preview.jpg";
  const std::string text =
      runScene(global, {"--preview", "depth", "--width", "160", "--out", out.string()});
  EXPECT_THAT(text, HasSubstr(std::to_string(last->planes->accumulated.size()) + " planes"));
  for (const auto& plane : last->planes->accumulated) {
    EXPECT_THAT(text, HasSubstr("plane " + std::string(plane.id < 10 ? "  " : " ") +
                                std::to_string(plane.id)));
  }
  const cv::Mat preview = cv::imread(out.string());
  EXPECT_EQ(preview.size(), cv::Size(160, 120));
}

TEST_F(SceneCommand, WatchPrintsAFullUpdateThenDeltas) {
  std::thread publisher([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    for (int i = 0; i < 3; ++i) {
      srv.hub().publish(*srv.cache().bySequence(last_frame->sequence));
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  const std::string text = runScene(global, {"--watch", "--count", "2"});
  publisher.join();
  EXPECT_THAT(text, HasSubstr(" full "));
  EXPECT_THAT(text, HasSubstr(" delta  planes 0 (-0)  things 0 (-0)"));
}

TEST_F(SceneCommand, ATimeBeforeTheCacheIsAnRpcError) {
  EXPECT_THROW(runScene(global, {"--at", "1"}), cli::RpcError);
}

}  // namespace
}  // namespace shapesense
