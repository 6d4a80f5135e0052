// ReplaySource and readTumIndex over small recordings built in scratch directories.

#include "shapesense/driver/replay_source.h"

#include <chrono>
#include <filesystem>
#include <future>
#include <string>
#include <thread>
#include <variant>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "recording_fixture.h"
#include "shapesense/core/geometry/timestamp.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using testing::RecordingBuilder;
using testing::scratchDir;
using namespace std::chrono_literals;

constexpr TimestampNs kT0 = 1'600'000'000'000'000'000LL;

TimestampNs ns(const std::string& text) {
  auto value = parseSecondsToNs(text);
  EXPECT_TRUE(value.has_value()) << text;
  return value.value_or(-1);
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  if (a.empty()) return true;
  cv::Mat diff;
  cv::compare(a.reshape(1), b.reshape(1), diff, cv::CMP_NE);
  return cv::countNonZero(diff) == 0;
}

ReplayOptions fast() { return ReplayOptions{.pacing = Pacing::kAsFastAsPossible}; }

SourceEvent pull(ReplaySource& source) {
  std::stop_source stop;
  return source.next(stop.get_token());
}

Frame expectFrame(ReplaySource& source) {
  SourceEvent event = pull(source);
  if (auto* error = std::get_if<SourceError>(&event)) {
    ADD_FAILURE() << "expected a frame, got SourceError: " << error->message;
    return {};
  }
  if (std::holds_alternative<EndOfStream>(event)) {
    ADD_FAILURE() << "expected a frame, got EndOfStream";
    return {};
  }
  return std::get<Frame>(std::move(event));
}

std::string expectError(ReplaySource& source) {
  SourceEvent event = pull(source);
  if (auto* error = std::get_if<SourceError>(&event)) return error->message;
  if (std::holds_alternative<EndOfStream>(event)) {
    ADD_FAILURE() << "expected a SourceError, got EndOfStream";
  } else {
    ADD_FAILURE() << "expected a SourceError, got frame " << std::get<Frame>(event).sequence;
  }
  return {};
}

void expectEnd(ReplaySource& source) {
  SourceEvent event = pull(source);
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(event)) << "index " << event.index();
}

// ---------------------------------------------------------------------------------------------
// Index parsing

std::filesystem::path recordingWithProblemLines(const std::string& name, const std::string& nl) {
  const auto dir = scratchDir(name);
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  builder.addDepth("1600000000.033333", 1);
  builder.addDepth("1600000000.066667", 2);
  // Hand-written depth.txt: comments, blank lines, two malformed lines.
  testing::writeTextFile(dir / "depth.txt",
                         "# depth maps" + nl +                                       // 1
                             "# timestamp filename" + nl +                           // 2
                             "1600000000.000000 depth/1600000000.000000.png" + nl +  // 3
                             nl +                                                    // 4
                             "yesterday depth/1600000000.033333.png" + nl +          // 5
                             "   # an indented comment" + nl +                       // 6
                             "1600000000.033333 depth/1600000000.033333.png" + nl +  // 7
                             "1600000000.050000" + nl +                              // 8: no path
                             "  \t " + nl +                                          // 9
                             "1600000000.066667 depth/1600000000.066667.png" + nl);  // 10
  return dir;
}

TEST(ReadTumIndex, SkipsCommentsAndReportsMalformedLinesWithFileAndLine) {
  const auto dir = recordingWithProblemLines("replay_index_lf", "\n");
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.depth.size(), 3u);
  EXPECT_EQ(index.depth[0].seconds_text, "1600000000.000000");
  EXPECT_EQ(index.depth[1].timestamp_ns, kT0 + 33'333'000);
  EXPECT_EQ(index.depth[2].relative_path, std::filesystem::path("depth/1600000000.066667.png"));
  ASSERT_EQ(index.problems.size(), 2u);
  const std::string depth_txt = (dir / "depth.txt").string();
  EXPECT_THAT(index.problems[0], HasSubstr(depth_txt + ":5"));
  EXPECT_THAT(index.problems[0], HasSubstr("yesterday"));
  EXPECT_THAT(index.problems[1], HasSubstr(depth_txt + ":8"));
  EXPECT_TRUE(index.rgb.empty());
}

TEST(ReadTumIndex, HandlesCrlfLineEndings) {
  const auto dir = recordingWithProblemLines("replay_index_crlf", "\r\n");
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.depth.size(), 3u);
  for (const auto& entry : index.depth) {
    EXPECT_EQ(entry.relative_path.string().find('\r'), std::string::npos) << entry.relative_path;
    EXPECT_EQ(entry.seconds_text.find('\r'), std::string::npos);
  }
  EXPECT_EQ(index.depth[2].relative_path, std::filesystem::path("depth/1600000000.066667.png"));
  ASSERT_EQ(index.problems.size(), 2u);
  EXPECT_THAT(index.problems[0], HasSubstr("depth.txt:5"));
  EXPECT_THAT(index.problems[1], HasSubstr("depth.txt:8"));
  for (const auto& problem : index.problems) EXPECT_EQ(problem.find('\r'), std::string::npos);

  // The frames behind CRLF lines load (no '\r' stuck to the file name).
  ReplaySource source(dir, fast());
  EXPECT_THAT(expectError(source), HasSubstr("depth.txt:5"));
  EXPECT_THAT(expectError(source), HasSubstr("depth.txt:8"));
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(expectFrame(source).sequence, static_cast<std::uint64_t>(i));
  expectEnd(source);
}

TEST(ReadTumIndex, RgbIndexIsSortedAndItsProblemsNamed) {
  const auto dir = scratchDir("replay_index_rgb");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("1600000000.000000");
  builder.finish();
  testing::writeTextFile(dir / "rgb.txt",
                         "# colour\n"
                         "1600000000.200000 rgb/b.png\n"
                         "1600000000.100000 rgb/a.png\n"
                         "1e9 rgb/c.png\n");
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.rgb.size(), 2u);
  EXPECT_EQ(index.rgb[0].relative_path, std::filesystem::path("rgb/a.png"));
  EXPECT_EQ(index.rgb[1].relative_path, std::filesystem::path("rgb/b.png"));
  ASSERT_EQ(index.problems.size(), 1u);
  EXPECT_THAT(index.problems[0], HasSubstr((dir / "rgb.txt").string() + ":4"));
}

TEST(ReplaySource, ReportsIndexProblemsAsSourceErrorsThenReplays) {
  const auto dir = recordingWithProblemLines("replay_problems", "\n");
  ReplaySource source(dir, fast());
  EXPECT_EQ(source.frameCount(), 3u);
  EXPECT_THAT(source.describe(), HasSubstr(dir.string()));
  EXPECT_THAT(expectError(source), HasSubstr("depth.txt:5"));
  EXPECT_THAT(expectError(source), HasSubstr("depth.txt:8"));
  const Frame f0 = expectFrame(source);
  const Frame f1 = expectFrame(source);
  const Frame f2 = expectFrame(source);
  EXPECT_EQ(f0.timestamp_ns, kT0);
  EXPECT_EQ(f1.timestamp_ns, kT0 + 33'333'000);
  EXPECT_EQ(f2.timestamp_ns, kT0 + 66'667'000);
  EXPECT_EQ(f0.sequence, 0u);
  EXPECT_EQ(f1.sequence, 1u);
  EXPECT_EQ(f2.sequence, 2u);
  expectEnd(source);
  expectEnd(source);  // stays ended
}

// ---------------------------------------------------------------------------------------------
// Units and camera.json

TEST(ReplaySource, ConvertsFiveThousandUnitsPerMetreToMillimetres) {
  const auto dir = scratchDir("replay_units_5000");
  RecordingBuilder builder(dir, 4, 2);
  builder.writeCamera(5000.0);
  cv::Mat units = (cv::Mat_<std::uint16_t>(2, 4) << 0, 5, 5000, 12345, 65535, 2500, 7, 10000);
  builder.addDepth("1600000000.000000", 0, units);
  builder.finish();
  ReplaySource source(dir, fast());
  const Frame frame = expectFrame(source);
  ASSERT_EQ(frame.depth.type(), CV_16UC1);
  cv::Mat expected_mm = (cv::Mat_<std::uint16_t>(2, 4) << 0, 1, 1000, 2469, 13107, 500, 1, 2000);
  EXPECT_TRUE(identical(frame.depth, expected_mm)) << frame.depth;
}

TEST(ReplaySource, UsesDepthScaleFromCameraJson) {
  cv::Mat units = (cv::Mat_<std::uint16_t>(2, 3) << 0, 1, 1234, 4000, 65531, 12344);
  {
    const auto dir = scratchDir("replay_units_1000");
    RecordingBuilder builder(dir, 3, 2);
    builder.writeCamera(1000.0);  // already millimetres
    builder.addDepth("1600000000.000000", 0, units);
    builder.finish();
    ReplaySource source(dir, fast());
    EXPECT_TRUE(identical(expectFrame(source).depth, units));
  }
  {
    const auto dir = scratchDir("replay_units_10000");
    RecordingBuilder builder(dir, 3, 2);
    builder.writeCamera(10000.0);  // tenths of a millimetre
    builder.addDepth("1600000000.000000", 0, units);
    builder.finish();
    ReplaySource source(dir, fast());
    cv::Mat expected_mm = (cv::Mat_<std::uint16_t>(2, 3) << 0, 0, 123, 400, 6553, 1234);
    const Frame frame = expectFrame(source);
    EXPECT_TRUE(identical(frame.depth, expected_mm)) << frame.depth;
  }
}

TEST(ReplaySource, IntrinsicsComeFromCameraJson) {
  const auto dir = scratchDir("replay_intrinsics");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera(5000.0, 111.5, 112.25, 3.75, 2.125);
  builder.addDepth("1600000000.000000");
  builder.finish();
  ReplaySource source(dir, fast());
  const Frame frame = expectFrame(source);
  EXPECT_EQ(frame.intrinsics, (CameraIntrinsics{111.5, 112.25, 3.75, 2.125, 8, 6}));
}

TEST(ReadRecordingCamera, DefaultsWhenAbsent) {
  const auto dir = scratchDir("replay_camera_absent");
  const RecordingCamera camera = readRecordingCamera(dir);
  EXPECT_EQ(camera.intrinsics, CameraIntrinsics{});
  EXPECT_EQ(camera.intrinsics.width, 640);
  EXPECT_EQ(camera.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(camera.intrinsics.fx, 525.0);
  EXPECT_DOUBLE_EQ(camera.depth_scale, 5000.0);
}

TEST(ReplaySource, WithoutCameraJsonReplaysKinectSizedFramesWithDefaults) {
  const auto dir = scratchDir("replay_camera_absent_replay");
  RecordingBuilder builder(dir, 640, 480);  // no writeCamera()
  builder.addDepth("1600000000.000000", 3);
  builder.finish();
  ASSERT_FALSE(std::filesystem::exists(dir / "camera.json"));
  ReplaySource source(dir, fast());
  const Frame frame = expectFrame(source);
  EXPECT_EQ(frame.intrinsics, CameraIntrinsics{});
  EXPECT_EQ(frame.depth.cols, 640);
  EXPECT_EQ(frame.depth.rows, 480);
}

TEST(ReadRecordingCamera, MissingFieldsKeepTheirDefaults) {
  const auto dir = scratchDir("replay_camera_partial");
  testing::writeTextFile(dir / "camera.json", R"({"fx": 600.0, "depth_scale": 1000})");
  const RecordingCamera camera = readRecordingCamera(dir);
  EXPECT_DOUBLE_EQ(camera.intrinsics.fx, 600.0);
  EXPECT_DOUBLE_EQ(camera.intrinsics.fy, 525.0);
  EXPECT_EQ(camera.intrinsics.width, 640);
  EXPECT_DOUBLE_EQ(camera.depth_scale, 1000.0);
}

void expectCameraError(const std::string& name, const std::string& text,
                       const std::string& mention) {
  SCOPED_TRACE(name + ": " + text);
  const auto dir = scratchDir(name);
  testing::writeTextFile(dir / "camera.json", text);
  try {
    readRecordingCamera(dir);
    ADD_FAILURE() << "no CameraFileError for camera.json " << text;
  } catch (const CameraFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "camera.json").string()));
    EXPECT_THAT(e.what(), HasSubstr(mention));
  }
}

TEST(ReadRecordingCamera, MalformedFileIsAClearError) {
  expectCameraError("camera_bad_json", "{\"fx\": 525.0,", "JSON");
  expectCameraError("camera_empty", "", "JSON");
  expectCameraError("camera_string_field", R"({"fx": "525"})", "fx");
  expectCameraError("camera_negative_fx", R"({"fx": -1.0})", "positive");
  expectCameraError("camera_zero_width", R"({"width": 0})", "positive");
  expectCameraError("camera_zero_scale", R"({"depth_scale": 0})", "positive");
}

TEST(ReadRecordingCamera, NonObjectJsonIsAnError) {
  // Valid JSON but not a camera description: silently using the defaults would replay with the
  // wrong intrinsics.
  for (const char* text : {"[525, 525, 319.5, 239.5]", "42", "\"camera\"", "null"}) {
    const auto dir = scratchDir("camera_not_object");
    testing::writeTextFile(dir / "camera.json", text);
    EXPECT_THROW(readRecordingCamera(dir), CameraFileError) << "camera.json: " << text;
  }
}

TEST(ReplaySource, MalformedCameraJsonFailsConstruction) {
  const auto dir = scratchDir("replay_camera_malformed");
  RecordingBuilder builder(dir);
  builder.writeCameraText("{ this is not json");
  builder.addDepth("1600000000.000000");
  builder.finish();
  try {
    ReplaySource source(dir, fast());
    FAIL() << "constructed over a malformed camera.json";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "camera.json").string()));
  }
}

// ---------------------------------------------------------------------------------------------
// Recordings that cannot be used at all

TEST(ReplaySource, MissingDirectoryThrowsNamingIt) {
  const auto dir = scratchDir("replay_missing_parent") / "no_such_recording";
  try {
    ReplaySource source(dir, fast());
    FAIL() << "constructed over a missing directory";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(dir.string()));
  }
}

TEST(ReplaySource, MissingDepthTxtThrowsNamingIt) {
  const auto dir = scratchDir("replay_missing_depth_txt");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addRgb("1600000000.000000");
  builder.finish();
  std::filesystem::remove(dir / "depth.txt");
  try {
    ReplaySource source(dir, fast());
    FAIL() << "constructed without depth.txt";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "depth.txt").string()));
  }
}

TEST(ReplaySource, DepthTxtWithoutEntriesThrows) {
  const auto dir = scratchDir("replay_empty_depth_txt");
  testing::writeTextFile(dir / "depth.txt", "# depth maps\n# timestamp filename\n");
  try {
    ReplaySource source(dir, fast());
    FAIL() << "constructed over an empty depth.txt";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "depth.txt").string()));
  }
}

// ---------------------------------------------------------------------------------------------
// Bad depth files: a SourceError naming the file, then the replay goes on

TEST(ReplaySource, BadDepthFilesAreReportedAndSkipped) {
  const auto dir = scratchDir("replay_bad_files");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  const std::string s[] = {"1600000000.000000", "1600000000.033333", "1600000000.066667",
                           "1600000000.100000", "1600000000.133333", "1600000000.166667",
                           "1600000000.200000", "1600000000.233333"};
  const cv::Mat good0 = builder.addDepth(s[0], 0);
  builder.listDepthOnly(s[1]);  // missing file
  builder.addDepth(s[2], 2);    // truncated below
  testing::truncateFile(builder.depthPath(s[2]),
                        std::filesystem::file_size(builder.depthPath(s[2])) / 2);
  builder.addDepth(s[3], 3, cv::Mat(6, 8, CV_8UC1, cv::Scalar(100)));  // 8-bit
  builder.addDepth(s[4], 4, testing::patternDepthUnits(10, 6, 4));     // wrong size
  builder.addDepth(s[5], 5);                                           // header only
  testing::truncateFile(builder.depthPath(s[5]), 20);
  builder.addDepth(s[6], 6, cv::Mat(6, 8, CV_16UC3, cv::Scalar(1000, 1000, 1000)));  // 3 channels
  const cv::Mat good7 = builder.addDepth(s[7], 7);
  builder.finish();

  ReplaySource source(dir, fast());
  const Frame first = expectFrame(source);
  EXPECT_EQ(first.timestamp_ns, ns(s[0]));
  EXPECT_EQ(first.sequence, 0u);
  EXPECT_TRUE(identical(first.depth, good0 / 5));
  for (int i : {1, 2, 3, 4, 5, 6}) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_THAT(expectError(source), HasSubstr(builder.depthPath(s[i]).string()));
  }
  const Frame last = expectFrame(source);
  EXPECT_EQ(last.timestamp_ns, ns(s[7]));
  EXPECT_EQ(last.sequence, 1u);  // sequence counts delivered frames
  EXPECT_TRUE(identical(last.depth, good7 / 5));
  expectEnd(source);
}

TEST(ReplaySource, WrongSizeMessageGivesBothSizes) {
  const auto dir = scratchDir("replay_wrong_size");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0, testing::patternDepthUnits(10, 7, 0));
  builder.finish();
  ReplaySource source(dir, fast());
  const std::string message = expectError(source);
  EXPECT_THAT(message, HasSubstr("10x7"));
  EXPECT_THAT(message, HasSubstr("8x6"));
  expectEnd(source);
}

TEST(ReplaySource, BadRgbCostsOnlyTheColour) {
  const auto dir = scratchDir("replay_bad_rgb");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  builder.addRgb("1600000000.000000", 0);
  testing::truncateFile(dir / "rgb" / "1600000000.000000.png", 30);
  builder.addDepth("1600000000.100000", 1);
  builder.rawRgbLine("1600000000.100000 rgb/missing.png");
  builder.finish();
  ReplaySource source(dir, fast());
  EXPECT_TRUE(expectFrame(source).rgb.empty());
  EXPECT_TRUE(expectFrame(source).rgb.empty());
  expectEnd(source);
}

// ---------------------------------------------------------------------------------------------
// RGB pairing

TEST(ReplaySource, PairsRgbWithinMaxOffsetOnly) {
  const auto dir = scratchDir("replay_rgb_pairing");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  const cv::Mat rgb_a = builder.addRgb("1600000000.015000", 1);  // +15 ms: paired
  builder.addDepth("1600000001.000000", 1);
  builder.addRgb("1600000001.025000", 2);  // +25 ms: too far
  builder.addDepth("1600000002.000000", 2);
  builder.addRgb("1600000001.985000", 3);                           // -15 ms
  const cv::Mat rgb_near = builder.addRgb("1600000002.004000", 4);  // +4 ms: the nearest
  builder.addDepth("1600000003.000000", 3);
  const cv::Mat rgb_edge = builder.addRgb("1600000003.020000", 5);  // exactly +20 ms: paired
  builder.addDepth("1600000004.000000", 4);
  builder.addRgb("1600000003.979999", 6);  // -20.001 ms: too far
  builder.finish();

  {
    ReplaySource source(dir, fast());
    const Frame f0 = expectFrame(source);
    const Frame f1 = expectFrame(source);
    const Frame f2 = expectFrame(source);
    const Frame f3 = expectFrame(source);
    const Frame f4 = expectFrame(source);
    EXPECT_TRUE(identical(f0.rgb, rgb_a));
    EXPECT_TRUE(f1.rgb.empty());
    EXPECT_TRUE(identical(f2.rgb, rgb_near));
    EXPECT_TRUE(identical(f3.rgb, rgb_edge));
    EXPECT_TRUE(f4.rgb.empty());
    expectEnd(source);
  }
  {
    ReplayOptions options = fast();
    options.max_rgb_offset = 30ms;
    ReplaySource source(dir, options);
    expectFrame(source);
    EXPECT_FALSE(expectFrame(source).rgb.empty());  // +25 ms now within reach
  }
  {
    ReplayOptions options = fast();
    options.max_rgb_offset = 3ms;
    ReplaySource source(dir, options);
    EXPECT_TRUE(expectFrame(source).rgb.empty());
    EXPECT_TRUE(expectFrame(source).rgb.empty());
    EXPECT_TRUE(expectFrame(source).rgb.empty());  // the nearest is 4 ms away
  }
}

// ---------------------------------------------------------------------------------------------
// Looping

TEST(ReplaySource, LoopShiftsTimestampsByTheRecordingLengthEachPass) {
  const auto dir = scratchDir("replay_loop");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  builder.addDepth("1600000000.100000", 1);
  builder.addDepth("1600000000.200000", 2);
  builder.finish();
  ReplayOptions options = fast();
  options.loop = true;
  ReplaySource source(dir, options);
  constexpr TimestampNs kPass = 300'000'000;  // last - first + one 100 ms period
  TimestampNs previous = -1;
  for (int pass = 0; pass < 4; ++pass) {
    for (int k = 0; k < 3; ++k) {
      const Frame frame = expectFrame(source);
      EXPECT_EQ(frame.timestamp_ns, kT0 + k * 100'000'000LL + pass * kPass) << pass << "/" << k;
      EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(pass * 3 + k));
      EXPECT_GT(frame.timestamp_ns, previous);
      previous = frame.timestamp_ns;
    }
  }
}

TEST(ReplaySource, LoopWithABadFileKeepsGoing) {
  const auto dir = scratchDir("replay_loop_bad");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  builder.listDepthOnly("1600000000.100000");
  builder.finish();
  ReplayOptions options = fast();
  options.loop = true;
  ReplaySource source(dir, options);
  for (int pass = 0; pass < 3; ++pass) {
    const Frame frame = expectFrame(source);
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(pass));
    EXPECT_EQ(frame.timestamp_ns, kT0 + pass * 200'000'000LL);
    EXPECT_THAT(expectError(source), HasSubstr("1600000000.100000.png"));
  }
}

// ---------------------------------------------------------------------------------------------
// Pacing

TEST(ReplaySource, RecordedPacingTakesAboutTheRecordedTime) {
  const auto dir = scratchDir("replay_pacing");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  for (int i = 0; i < 4; ++i) builder.addDepth("1600000000." + std::to_string(i) + "00000", i);
  builder.finish();
  ReplaySource source(dir, ReplayOptions{.pacing = Pacing::kRecorded});
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 4; ++i) expectFrame(source);
  const auto elapsed = std::chrono::steady_clock::now() - start;
  expectEnd(source);
  // The recording spans 300 ms.
  EXPECT_GE(elapsed, 240ms);
}

TEST(ReplaySource, AsFastAsPossibleDoesNotSleep) {
  const auto dir = scratchDir("replay_no_pacing");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  builder.addDepth("1600000030.000000", 1);  // 30 s later
  builder.finish();
  ReplaySource source(dir, fast());
  auto done = std::async(std::launch::async, [&] {
    expectFrame(source);
    expectFrame(source);
  });
  ASSERT_EQ(done.wait_for(5s), std::future_status::ready) << "kAsFastAsPossible slept";
}

TEST(ReplaySource, StopInterruptsALongPacingSleep) {
  const auto dir = scratchDir("replay_stop");
  RecordingBuilder builder(dir, 8, 6);
  builder.writeCamera();
  builder.addDepth("1600000000.000000", 0);
  builder.addDepth("1600000030.000000", 1);  // 30 s gap
  builder.finish();
  ReplaySource source(dir, ReplayOptions{.pacing = Pacing::kRecorded});
  std::stop_source stop;
  SourceEvent first = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<Frame>(first));
  std::jthread stopper([&] {
    std::this_thread::sleep_for(100ms);
    stop.request_stop();
  });
  const auto start = std::chrono::steady_clock::now();
  auto result = std::async(std::launch::async, [&] { return source.next(stop.get_token()); });
  ASSERT_EQ(result.wait_for(5s), std::future_status::ready) << "next() ignored the stop request";
  const SourceEvent second = result.get();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(second)) << second.index();
}

TEST(ReplaySource, AlreadyStoppedTokenEndsAtOnce) {
  const auto path = testing::makeSmallRecording("replay_prestopped", 2);
  ReplaySource source(path, fast());
  std::stop_source stop;
  stop.request_stop();
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

// ---------------------------------------------------------------------------------------------
// A real recording

TEST(ReplaySource, RealTumFr2Desk) {
  const auto dir = testing::realRecording("tum_fr2_desk");
  if (!std::filesystem::exists(dir / "depth.txt")) GTEST_SKIP() << "shared data missing: " << dir;
  ReplaySource source(dir, fast());
  EXPECT_EQ(source.frameCount(), 2u);
  const CameraIntrinsics expected{520.9, 521.0, 325.1, 249.7, 640, 480};
  const Frame f0 = expectFrame(source);
  const Frame f1 = expectFrame(source);
  expectEnd(source);
  for (const Frame* f : {&f0, &f1}) {
    EXPECT_EQ(f->intrinsics, expected);
    EXPECT_EQ(f->depth.type(), CV_16UC1);
    EXPECT_EQ(f->depth.cols, 640);
    EXPECT_EQ(f->depth.rows, 480);
    EXPECT_EQ(f->rgb.type(), CV_8UC3);
    EXPECT_EQ(f->rgb.size(), f->depth.size());
    // A desk at about 1-3 m: most pixels have a reading, on average in a plausible range.
    EXPECT_GT(cv::countNonZero(f->depth), 640 * 480 / 2);
    const double mean_mm = cv::mean(f->depth, f->depth > 0)[0];
    EXPECT_GT(mean_mm, 500.0);
    EXPECT_LT(mean_mm, 5000.0);
  }
  // Exactly the PNG's units divided by 5 (5000 units/m -> mm).
  const TumIndex index = readTumIndex(dir);
  for (std::size_t i = 0; i < 2; ++i) {
    cv::Mat units = cv::imread((dir / index.depth[i].relative_path).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(units.type(), CV_16UC1);
    cv::Mat mm;
    units.convertTo(mm, CV_16UC1, 0.2);
    EXPECT_TRUE(identical((i == 0 ? f0 : f1).depth, mm)) << "frame " << i;
  }
  EXPECT_EQ(f0.timestamp_ns, kT0);
  EXPECT_EQ(f1.timestamp_ns, kT0 + 33'333'000);
  EXPECT_EQ(f0.sequence, 0u);
  EXPECT_EQ(f1.sequence, 1u);
}

}  // namespace
}  // namespace shapesense
