// Tests of writeSyntheticRecording: the TUM part, the truth images and truth.jsonl.

#include "shapesense/driver/synthetic_recording.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/driver/tum_recording.h"
#include "test_paths.h"

namespace shapesense::synthetic {
namespace {

TEST(SyntheticRecording, WritesTumFramesTruthImagesAndJsonLines) {
  const auto dir = testing::scratchDir("synthetic_recording");
  SceneParams params;
  params.seed = 3;
  const TimestampNs start = 1'700'000'000'000'000'000;
  writeSyntheticRecording(dir, params, 3, start, 10.0);

  const TumIndex index = readTumIndex(dir);
  EXPECT_TRUE(index.problems.empty());
  ASSERT_EQ(index.depth.size(), 3u);
  EXPECT_EQ(index.rgb.size(), 3u);
  EXPECT_EQ(index.camera.intrinsics, params.intrinsics);

  SceneParams as_recorded = params;
  as_recorded.frame_rate_hz = 10.0;
  const SyntheticScene scene(as_recorded);
  std::ifstream jsonl(dir / "truth.jsonl");
  for (std::uint64_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    const TumIndexEntry& entry = index.depth[i];
    EXPECT_EQ(entry.timestamp_ns, start + static_cast<TimestampNs>(i) * 100'000'000);
    const RenderedFrame expected = scene.render(i, entry.timestamp_ns);

    // Depth round-trips through the 5000/m PNG to the millimetre.
    const cv::Mat depth_units =
        cv::imread((dir / entry.relative_path).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth_units.type(), CV_16UC1);
    cv::Mat depth_mm;
    depth_units.convertTo(depth_mm, CV_16UC1, 1000.0 / index.camera.depth_scale);
    EXPECT_EQ(cv::norm(depth_mm, expected.frame.depth, cv::NORM_INF), 0.0);

    for (const auto& [suffix, labels] :
         {std::pair{".surfaces.png", &expected.truth.surface_labels},
          std::pair{".objects.png", &expected.truth.object_labels}}) {
      const cv::Mat read = cv::imread((dir / "truth" / (entry.seconds_text + suffix)).string(),
                                      cv::IMREAD_UNCHANGED);
      ASSERT_EQ(read.type(), CV_16UC1) << suffix;
      EXPECT_EQ(cv::norm(read, *labels, cv::NORM_INF), 0.0) << suffix;
    }

    std::string line;
    ASSERT_TRUE(std::getline(jsonl, line));
    const nlohmann::json j = nlohmann::json::parse(line);
    EXPECT_EQ(j.at("timestamp").get<std::string>(), entry.seconds_text);
    EXPECT_EQ(j.at("timestamp_ns").get<TimestampNs>(), entry.timestamp_ns);
    EXPECT_EQ(j.at("sequence").get<std::uint64_t>(), i);
    ASSERT_EQ(j.at("surfaces").size(), expected.truth.surfaces.size());
    ASSERT_EQ(j.at("objects").size(), expected.truth.objects.size());
    const nlohmann::json& floor = j.at("surfaces").at(4);  // room faces come first
    EXPECT_EQ(floor.at("name"), "floor");
    EXPECT_EQ(floor.at("kind"), "plane");
    EXPECT_NEAR(floor.at("plane").at(3).get<double>(), expected.truth.surfaces[4].plane.w(), 1e-12);
    EXPECT_EQ(floor.at("pixel_count").get<std::size_t>(), expected.truth.surfaces[4].pixel_count);
    for (const nlohmann::json& o : j.at("objects")) {
      EXPECT_EQ(o.at("corners").size(), 8u);
      EXPECT_EQ(o.contains("view_class"), o.at("kind") == "bowl");
    }
    EXPECT_NEAR(j.at("world_from_camera").at(2).at(3).get<double>(),
                expected.truth.world_from_camera.translation().z(), 1e-12);
  }
  std::string extra;
  EXPECT_FALSE(std::getline(jsonl, extra) && !extra.empty());
}

}  // namespace
}  // namespace shapesense::synthetic
