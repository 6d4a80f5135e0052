// `shapesense teach`, `objects` and `find` against a real in-process gRPC server whose cache
// holds a synthetic scene with the detectors' results: the text, --json and find's --overlay.

#include <algorithm>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "object_scene.h"
#include "shapesense/core/geometry/timestamp.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using ::testing::HasSubstr;
using testing::kServerT0;

// Prints what `shapesense <args>` printed; CLI11 takes its arguments reversed.
std::string run(const cli::GlobalOptions& global, std::vector<std::string> args) {
  CLI::App app;
  cli::addTeachCommand(app, global);
  cli::addObjectsCommand(app, global);
  cli::addFindCommand(app, global);
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

class ObjectCommands : public ::testing::Test {
 protected:
  void SetUp() override {
    global.server = "127.0.0.1:" + std::to_string(srv.port());
    global.timeout_s = 60;  // a loaded machine; the calls' own speed is not tested here
    const cv::Rect r = scene.roi("box1");
    roi = std::to_string(r.x) + "," + std::to_string(r.y) + "," +
          std::to_string(r.x + r.width - 1) + "," + std::to_string(r.y + r.height - 1);
  }

  std::string teach(const std::string& name, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {
        "teach", "--at", formatNsAsSeconds(kServerT0, 9), "--roi", roi, "--name", name};
    args.insert(args.end(), extra.begin(), extra.end());
    return run(global, args);
  }

  testing::TestServer srv{16, {}, {}, testing::patientLimits()};
  testing::ObjectScene scene{srv};
  cli::GlobalOptions global;
  std::string roi;
};

TEST_F(ObjectCommands, TeachObjectsAndFindInText) {
  EXPECT_THAT(teach("box1"), HasSubstr("taught box1 from frame"));
  EXPECT_THAT(teach("box1", {"--replace"}), HasSubstr("replaced box1"));
  const std::string listed = run(global, {"objects"});
  EXPECT_THAT(listed, HasSubstr("1 taught objects (at most 32)"));
  EXPECT_THAT(listed, HasSubstr("box1"));
  const std::string found =
      run(global, {"find", "--at", formatNsAsSeconds(kServerT0, 9), "--names", "box1"});
  EXPECT_THAT(found, HasSubstr("1 objects found"));
  EXPECT_THAT(found, HasSubstr("box1"));
}

TEST_F(ObjectCommands, JsonAnswersAreTheMessages) {
  const auto taught = nlohmann::json::parse(teach("box1", {"--json"}));
  EXPECT_EQ(taught["model"]["name"], "box1");
  EXPECT_EQ(taught["frame_timestamp_ns"], std::to_string(kServerT0));
  const auto listed = nlohmann::json::parse(run(global, {"objects", "--json"}));
  ASSERT_EQ(listed["models"].size(), 1u);
  EXPECT_EQ(listed["models"][0]["feature_count"], taught["model"]["feature_count"]);
  const auto found = nlohmann::json::parse(
      run(global, {"find", "--at", formatNsAsSeconds(kServerT0, 9), "--json"}));
  ASSERT_EQ(found["detections"].size(), 1u);
  EXPECT_EQ(found["detections"][0]["name"], "box1");
  EXPECT_GE(found["detections"][0]["score"].get<double>(), 0.85);
}

TEST_F(ObjectCommands, FindWritesAnOverlayPng) {
  teach("box1");
  const auto out = testing::scratchDir("find-overlay") / "found.png";
  const std::string printed =
      run(global, {"find", "--at", formatNsAsSeconds(kServerT0, 9), "--overlay", out.string()});
  EXPECT_THAT(printed, HasSubstr("overlay written to"));
  const cv::Mat image = cv::imread(out.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
}

TEST_F(ObjectCommands, ErrorsAreTheDaemonsWords) {
  teach("box1");
  try {
    teach("box1");
    FAIL() << "a taken name was accepted";
  } catch (const cli::RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::ALREADY_EXISTS);
  }
  try {
    run(global, {"find", "--names", "box1,teapot"});
    FAIL() << "an unknown name was accepted";
  } catch (const cli::RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::NOT_FOUND);
    EXPECT_THAT(std::string(e.what()), HasSubstr("teapot"));
  }
  EXPECT_THROW(run(global, {"teach", "--roi", "1,2,3", "--name", "x"}), CLI::ValidationError);
}

}  // namespace
}  // namespace shapesense
