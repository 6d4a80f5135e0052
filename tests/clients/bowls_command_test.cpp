// `shapesense bowls` against a real in-process gRPC server whose cache holds synthetic frames
// with the real bowl stage's results: the table, --json and the --out overlay.

#include <algorithm>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "server_fixture.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/synthetic_scene.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using ::testing::HasSubstr;
using testing::kServerT0;

// Prints what the command printed; CLI11 takes its arguments reversed.
std::string runBowls(const cli::GlobalOptions& global, std::vector<std::string> args) {
  CLI::App app;
  cli::addBowlsCommand(app, global);
  args.insert(args.begin(), "bowls");
  std::reverse(args.begin(), args.end());
  ::testing::internal::CaptureStdout();
  try {
    app.parse(args);
  } catch (...) {
    ::testing::internal::GetCapturedStdout();
    throw;
  }
  return ::testing::internal::GetCapturedStdout();
}

class BowlsCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    DetectorConfig config;
    config.segmentation.reset();
    config.planes.reset();
    config.bowl_models = std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
    // A held-out scene (see tests/server/get_bowls_test.cpp) whose frame holds bowls.
    synthetic::SceneParams params;
    params.seed = 515151;
    auto rendered = synthetic::SyntheticScene(params).render(0, kServerT0);
    frame = std::make_shared<const Frame>(std::move(rendered.frame));
    ASSERT_TRUE(srv.cache().insert(frame));
    results = std::make_shared<const FrameResults>(makeDetectorChain(config).process(*frame));
    ASSERT_TRUE(srv.cache().publishResults(frame->sequence, results));
    ASSERT_FALSE(results->bowls->empty())
        << "the scene must hold a detected bowl to test the command";
    global.server = "127.0.0.1:" + std::to_string(srv.port());
  }

  testing::TestServer srv;
  std::shared_ptr<const Frame> frame;
  std::shared_ptr<const FrameResults> results;
  cli::GlobalOptions global;
};

TEST_F(BowlsCommand, JsonHoldsEveryBowlOfTheFrame) {
  const auto json = nlohmann::json::parse(runBowls(global, {"--json"}));
  const auto& bowls = *results->bowls;
  EXPECT_EQ(json["info"]["timestamp_ns"], std::to_string(kServerT0));  // int64 is a string in JSON
  ASSERT_EQ(json["bowls"].size(), bowls.size());
  for (std::size_t i = 0; i < bowls.size(); ++i) {
    const auto& got = json["bowls"][i];
    EXPECT_EQ(got["box"]["x"], bowls[i].detection.box.x);
    EXPECT_EQ(got["box"]["width"], bowls[i].detection.box.width);
    EXPECT_DOUBLE_EQ(got["score"].get<double>(), bowls[i].detection.score);
    EXPECT_EQ(got["view"], bowls[i].detection.view);
    EXPECT_EQ(got["corners"].size(), bowls[i].box ? 8u : 0u);
  }
}

TEST_F(BowlsCommand, TableAndOverlay) {
  const auto out = testing::scratchDir("bowls_command") / "bowls.png";
  const std::string text = runBowls(global, {"--at", "1700000000", "--out", out.string()});
  EXPECT_THAT(text, HasSubstr(std::to_string(results->bowls->size()) + " bowls"));
  for (const auto& bowl : *results->bowls) EXPECT_THAT(text, HasSubstr(bowl.detection.view));
  EXPECT_THAT(text, HasSubstr("overlay written to " + out.string()));

  const cv::Mat overlay = cv::imread(out.string(), cv::IMREAD_COLOR);
  ASSERT_EQ(overlay.size(), frame->rgb.size());
  // The last bowl drawn is on top: the middle of its box's bottom edge has its view's colour,
  // where the frame itself almost surely has not.
  const cv::Rect box = results->bowls->back().detection.box;
  const cv::Point edge(box.x + box.width / 2, box.y + box.height - 1);
  const cv::Vec3b drawn = overlay.at<cv::Vec3b>(edge);
  const std::map<std::string, cv::Vec3b> colours{
      {"top", {255, 160, 0}}, {"middle", {0, 220, 255}}, {"side", {255, 0, 255}}};
  EXPECT_EQ(drawn, colours.at(results->bowls->back().detection.view));
  EXPECT_GT(cv::norm(overlay, frame->rgb, cv::NORM_L1), 0.0);
}

TEST_F(BowlsCommand, WithoutAtTheNewestProcessedFrameIsUsed) {
  // A newer frame the detectors have not processed yet, as in a daemon whose source is faster.
  ASSERT_TRUE(srv.cache().insert(std::make_shared<const Frame>(
      testing::makeTestFrame(kServerT0 + testing::kFramePeriodNs, frame->sequence + 1))));
  const auto json = nlohmann::json::parse(runBowls(global, {"--json"}));
  EXPECT_EQ(json["info"]["timestamp_ns"], std::to_string(kServerT0));
  EXPECT_EQ(json["bowls"].size(), results->bowls->size());
  // Asked for explicitly, the unprocessed frame is the daemon's error.
  EXPECT_THROW(runBowls(global, {"--at", "1700000000.04"}), cli::RpcError);
}

TEST(BowlsCommandErrors, StageOffIsReportedWithItsStatus) {
  testing::TestServer srv;
  srv.add(kServerT0);  // results without a bowl stage
  cli::GlobalOptions global;
  global.server = "127.0.0.1:" + std::to_string(srv.port());
  try {
    runBowls(global, {});
    FAIL() << "no error for a daemon without the bowl stage";
  } catch (const cli::RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_THAT(e.what(), HasSubstr("--bowls on"));
  }
}

}  // namespace
}  // namespace shapesense
