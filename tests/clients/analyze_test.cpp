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
#include "shapesense/core/timestamp.h"
#include "shapesense/driver/tum_recording.h"
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
  if (!std::filesystem::exists(recording / "depth.txt")) GTEST_SKIP() << "shared data missing: " << recording;
  const auto out = shapesense::testing::scratchDir("analyze_mosd");
  std::vector<std::pair<std::size_t, std::size_t>> progress;
  const AnalyzeSummary summary =
      analyzeRecording(recording, out, makeDetectorChain({}),
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
  if (!std::filesystem::exists(source / "depth.txt")) GTEST_SKIP() << "shared data missing: " << source;
  const auto scratch = shapesense::testing::scratchDir("analyze_corrupt");
  const auto recording = scratch / "recording";
  shapesense::testing::copyRecording(source, recording);
  const auto stamps = depthStamps(recording);
  ASSERT_EQ(stamps.size(), 6u);
  const auto victim = recording / readTumIndex(recording).depth[3].relative_path;
  shapesense::testing::truncateFile(victim, std::filesystem::file_size(victim) / 3);

  const AnalyzeSummary summary = analyzeRecording(recording, scratch / "out", makeDetectorChain({}));
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

TEST(Analyze, MissingRecordingThrows) {
  const auto dir = shapesense::testing::scratchDir("analyze_missing");
  EXPECT_THROW(analyzeRecording(dir / "nothing", dir / "out", makeDetectorChain({})), std::runtime_error);
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
