// `shapesense analyze`: the detector chain over a recording into results.jsonl.

#include "analyze.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "recording_fixture.h"
#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/core/pipeline/stages.h"
#include "shapesense/driver/replay_source.h"
#include "shapesense/driver/synthetic_recording.h"
#include "shapesense/driver/tum_recording.h"
#include "shapesense/server/pipeline.h"
#include "test_paths.h"

namespace shapesense::cli {
namespace {

std::vector<std::string> readLines(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// The text of the "timestamp" number exactly as written in the JSON line.
std::string rawTimestamp(const std::string& line) {
  const std::string key = "\"timestamp\":";
  const auto at = line.find(key);
  if (at == std::string::npos) return {};
  const auto begin = at + key.size();
  const auto end = line.find_first_of(",}", begin);
  return line.substr(begin, end - begin);
}

// "1600000000.100000" and "1600000000.1" are the same decimal: drop trailing fraction zeros.
std::string canonicalDecimal(std::string text) {
  if (text.find('.') == std::string::npos) return text + ".0";
  while (text.back() == '0') text.pop_back();
  if (text.back() == '.') text += '0';
  return text;
}

std::vector<std::string> depthStamps(const std::filesystem::path& recording) {
  std::vector<std::string> stamps;
  for (const auto& entry : readTumIndex(recording).depth) stamps.push_back(entry.seconds_text);
  return stamps;
}

void expectResultLine(const std::string& line, const std::string& stamp) {
  SCOPED_TRACE(line.substr(0, 200));
  // The number as written is the stamp of depth.txt, digit for digit.
  EXPECT_EQ(canonicalDecimal(rawTimestamp(line)), canonicalDecimal(stamp));
  EXPECT_EQ(parseSecondsToNs(rawTimestamp(line)), parseSecondsToNs(stamp));
  const auto json = nlohmann::json::parse(line);
  ASSERT_TRUE(json.contains("timestamp"));
  EXPECT_TRUE(json["timestamp"].is_number());
  ASSERT_TRUE(json.contains("planes"));
  EXPECT_TRUE(json["planes"].is_array());
  ASSERT_TRUE(json.contains("bowls"));
  EXPECT_TRUE(json["bowls"].is_array());
  ASSERT_TRUE(json.contains("timings_ms"));
  ASSERT_TRUE(json["timings_ms"].contains("depth_stats"));
  EXPECT_TRUE(json["timings_ms"]["depth_stats"].is_number());
  EXPECT_GE(json["timings_ms"]["depth_stats"].get<double>(), 0.0);
}

TEST(Analyze, MosdTabletopWritesOneLinePerFrameInOrder) {
  const auto recording = shapesense::testing::realRecording("mosd_tabletop");
  if (!std::filesystem::exists(recording / "depth.txt"))
    GTEST_SKIP() << "shared data missing: " << recording;
  const auto out = shapesense::testing::scratchDir("analyze_mosd");
  std::vector<std::pair<std::size_t, std::size_t>> progress;
  const AnalyzeSummary summary = analyzeRecording(
      recording, out, makeDetectorChain({}),
      [&](std::size_t done, std::size_t total) { progress.emplace_back(done, total); });
  EXPECT_EQ(summary.frames, 6u);
  EXPECT_EQ(summary.bad_frames, 0u);
  const auto lines = readLines(out / "results.jsonl");
  const auto stamps = depthStamps(recording);
  ASSERT_EQ(stamps.size(), 6u);
  ASSERT_EQ(lines.size(), 6u);
  for (std::size_t i = 0; i < lines.size(); ++i) expectResultLine(lines[i], stamps[i]);
  // e.g. the second frame: exactly 1600000000.033333, not 1600000000.0333331.
  EXPECT_EQ(rawTimestamp(lines[1]), "1600000000.033333");
  EXPECT_EQ(rawTimestamp(lines[2]), "1600000000.066667");
  ASSERT_EQ(progress.size(), 6u);
  EXPECT_EQ(progress.back(), (std::pair<std::size_t, std::size_t>{6, 6}));
}

TEST(Analyze, CorruptFrameIsLeftOutAndCounted) {
  const auto source = shapesense::testing::realRecording("mosd_tabletop");
  if (!std::filesystem::exists(source / "depth.txt"))
    GTEST_SKIP() << "shared data missing: " << source;
  const auto scratch = shapesense::testing::scratchDir("analyze_corrupt");
  const auto recording = scratch / "recording";
  shapesense::testing::copyRecording(source, recording);
  const auto stamps = depthStamps(recording);
  ASSERT_EQ(stamps.size(), 6u);
  const auto victim = recording / readTumIndex(recording).depth[3].relative_path;
  shapesense::testing::truncateFile(victim, std::filesystem::file_size(victim) / 3);

  const AnalyzeSummary summary =
      analyzeRecording(recording, scratch / "out", makeDetectorChain({}));
  EXPECT_EQ(summary.frames, 5u);
  EXPECT_EQ(summary.bad_frames, 1u);
  const auto lines = readLines(scratch / "out" / "results.jsonl");
  ASSERT_EQ(lines.size(), 5u);
  const std::vector<std::string> expected = {stamps[0], stamps[1], stamps[2], stamps[4], stamps[5]};
  for (std::size_t i = 0; i < lines.size(); ++i) expectResultLine(lines[i], expected[i]);
}

TEST(Analyze, SmallScratchRecordingWithAMissingFile) {
  const auto dir = shapesense::testing::scratchDir("analyze_small");
  shapesense::testing::RecordingBuilder builder(dir / "rec");
  builder.writeCamera();
  builder.addDepth("1700000000.000001", 0);
  builder.listDepthOnly("1700000000.033334");
  builder.addDepth("1700000000.100000", 2);
  builder.finish();
  const AnalyzeSummary summary = analyzeRecording(dir / "rec", dir / "out", makeDetectorChain({}));
  EXPECT_EQ(summary.frames, 2u);
  EXPECT_EQ(summary.bad_frames, 1u);
  const auto lines = readLines(dir / "out" / "results.jsonl");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(rawTimestamp(lines[0]), "1700000000.000001");
  EXPECT_EQ(canonicalDecimal(rawTimestamp(lines[1])), "1700000000.1");
}

TEST(Analyze, KeepsTheFramesADaemonReplayingTheRecordingKeeps) {
  // Stamps that go back (line 3) or repeat (line 4): the daemon's cache refuses such frames, so
  // analyze must leave them out too, or its results list frames no daemon ever served.
  const auto dir = shapesense::testing::scratchDir("analyze_time_back");
  shapesense::testing::RecordingBuilder builder(dir / "rec");
  builder.writeCamera();
  for (const char* stamp : {"1700000000.000000", "1700000000.100000", "1700000000.050000",
                            "1700000000.100000", "1700000000.200000"}) {
    builder.addDepth(stamp);
  }
  builder.finish();
  DetectorChain analyze_chain;
  analyze_chain.add(std::make_unique<DepthStatsStage>());
  const AnalyzeSummary summary = analyzeRecording(dir / "rec", dir / "out", analyze_chain);
  std::vector<std::string> analyzed;
  for (const auto& line : readLines(dir / "out" / "results.jsonl"))
    analyzed.push_back(canonicalDecimal(rawTimestamp(line)));

  FrameCache cache(16);
  SummaryHub hub;
  DetectorChain daemon_chain;
  daemon_chain.add(std::make_unique<DepthStatsStage>());
  Pipeline pipeline(std::make_unique<ReplaySource>(
                        dir / "rec", ReplayOptions{.pacing = Pacing::kAsFastAsPossible}),
                    std::move(daemon_chain), cache, hub);
  pipeline.start();
  ASSERT_TRUE(pipeline.waitUntilDrained(std::chrono::seconds(10)));
  EXPECT_EQ(pipeline.status().frames_out_of_order, 0u);
  std::vector<std::string> served;
  for (const auto& entry : cache.list())
    served.push_back(canonicalDecimal(formatNsAsSeconds(entry.frame->timestamp_ns, 6)));

  EXPECT_EQ(summary.frames, 3u);
  EXPECT_EQ(summary.bad_frames, 2u);  // the two skipped lines, reported
  EXPECT_THAT(analyzed, ::testing::ElementsAre("1700000000.0", "1700000000.1", "1700000000.2"));
  EXPECT_EQ(served, analyzed);
}

TEST(Analyze, MissingRecordingThrows) {
  const auto dir = shapesense::testing::scratchDir("analyze_missing");
  EXPECT_THROW(analyzeRecording(dir / "nothing", dir / "out", makeDetectorChain({})),
               std::runtime_error);
}

// A held-out synthetic scene with a raised camera (bowls seen from 20-60 degrees) as a recording
// with truth.jsonl; the same one tests/server/get_bowls_test.cpp checks through the daemon.
std::filesystem::path bowlRecording(const std::filesystem::path& dir) {
  synthetic::SceneParams params;
  params.seed = 515152;
  params.camera_height_min_m = 1.3;
  params.camera_height_max_m = 1.6;
  params.table_distance_min_m = 1.1;
  params.table_distance_max_m = 1.8;
  params.min_table_elevation_deg = 17.0;
  synthetic::writeSyntheticRecording(dir / "rec", params, 2, 1'700'000'000'000'000'000LL);
  return dir / "rec";
}

DetectorConfig bowlsOnly(bool bowls) {
  DetectorConfig config;
  config.segmentation.reset();
  config.planes.reset();
  config.bowls = bowls;
  config.bowl_models = std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
  return config;
}

TEST(Analyze, BowlsOfASyntheticRecordingMatchItsTruth) {
  const auto dir = shapesense::testing::scratchDir("analyze_bowls");
  const auto recording = bowlRecording(dir);
  analyzeRecording(recording, dir / "out", makeDetectorChain(bowlsOnly(true)));
  const auto lines = readLines(dir / "out" / "results.jsonl");
  const auto truths = readLines(recording / "truth.jsonl");
  ASSERT_EQ(lines.size(), 2u);
  ASSERT_EQ(truths.size(), 2u);
  const double threshold =
      BowlDetector::load(defaultBowlModelsDir()).operatingPoint().score_threshold;
  int truth_bowls = 0, found = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto json = nlohmann::json::parse(lines[i]);
    ASSERT_TRUE(json["timings_ms"].contains("bowls"));
    std::vector<cv::Rect> boxes;
    double previous_score = 1e300;
    for (const auto& bowl : json["bowls"]) {
      ASSERT_EQ(bowl["box"].size(), 4u);
      boxes.emplace_back(bowl["box"][0].get<int>(), bowl["box"][1].get<int>(),
                         bowl["box"][2].get<int>(), bowl["box"][3].get<int>());
      EXPECT_THAT(bowl["view"].get<std::string>(), ::testing::AnyOf("top", "middle", "side"));
      const double score = bowl["score"].get<double>();
      EXPECT_GE(score, threshold);
      EXPECT_LE(score, previous_score) << "not highest score first";
      previous_score = score;
    }
    // Every upright bowl the truth shows whole enough (at least 40 px wide) is in the list with
    // an IoU of at least 0.5 (PASCAL VOC's match).
    const auto truth_json = nlohmann::json::parse(truths[i]);
    for (const auto& object : truth_json["objects"]) {
      if (object["kind"] != "bowl" || !object["upright"].get<bool>()) continue;
      const auto& b = object["image_box"];
      const cv::Rect truth(b[0].get<int>(), b[1].get<int>(), b[2].get<int>(), b[3].get<int>());
      if (truth.width < 40 || object["pixel_count"].get<double>() < 0.25 * truth.area()) continue;
      ++truth_bowls;
      double best = 0.0;
      for (const auto& box : boxes) best = std::max(best, boxIoU(box, truth));
      found += best >= 0.5;
    }
  }
  ASSERT_GT(truth_bowls, 0) << "the scene must show a bowl";
  EXPECT_EQ(found, truth_bowls);
}

TEST(Analyze, BowlsOffLeavesTheListEmptyAndNeedsNoModels) {
  const auto dir = shapesense::testing::scratchDir("analyze_bowls_off");
  const auto recording = bowlRecording(dir);
  DetectorConfig config = bowlsOnly(false);
  config.bowl_models = dir / "no_models_here";
  analyzeRecording(recording, dir / "out", makeDetectorChain(config));
  const auto lines = readLines(dir / "out" / "results.jsonl");
  ASSERT_EQ(lines.size(), 2u);
  for (const auto& line : lines) {
    const auto json = nlohmann::json::parse(line);
    EXPECT_TRUE(json["bowls"].is_array());
    EXPECT_TRUE(json["bowls"].empty());
    EXPECT_FALSE(json["timings_ms"].contains("bowls"));
  }
}

TEST(Analyze, BowlsOnWithoutModelsThrowsNamingTheFolder) {
  const auto dir = shapesense::testing::scratchDir("analyze_bowls_no_models");
  DetectorConfig config = bowlsOnly(true);
  config.bowl_models = dir / "no_models_here";
  try {
    makeDetectorChain(config);
    FAIL() << "a chain with bowls on and no models";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr((dir / "no_models_here").string()));
  }
}

TEST(SecondsForJson, PrintsTheShortestExactDecimal) {
  auto text = [](TimestampNs ns) { return nlohmann::json(secondsForJson(ns)).dump(); };
  EXPECT_EQ(text(1600000000033333000LL), "1600000000.033333");
  EXPECT_EQ(text(1600000000066667000LL), "1600000000.066667");
  EXPECT_EQ(text(1700000000123456000LL), "1700000000.123456");
  EXPECT_EQ(canonicalDecimal(text(1600000000000000000LL)), "1600000000.0");
  // Every microsecond stamp of a 30 fps second prints back as its 6-decimal text.
  for (int i = 0; i < 30; ++i) {
    const TimestampNs ns = 1700000000000000000LL + (i * 1'000'000'000LL / 30) / 1000 * 1000;
    EXPECT_EQ(canonicalDecimal(text(ns)), canonicalDecimal(formatNsAsSeconds(ns, 6))) << i;
  }
}

}  // namespace
}  // namespace shapesense::cli
