// Fakenect dumps: writer -> own reader round trip against synthetic frames, file validation,
// and the errors a bad dump produces.

#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/kinect_raw.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <variant>
#include <vector>

#include "depth_compare.h"
#include "synthetic_frames.h"
#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
constexpr std::uint64_t kSeed = 7;

std::vector<std::string> readLines(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(FakenectDump, ParsesRecordNames) {
  const auto entry = parseFakenectName("d-1294953344.603617-1003577.pgm");
  ASSERT_TRUE(entry.has_value());
  EXPECT_EQ(entry->type, 'd');
  EXPECT_EQ(entry->host_ns, 1'294'953'344'603'617'000);
  EXPECT_EQ(entry->device_ticks, 1003577u);
  EXPECT_TRUE(parseFakenectName("a-1.5-42-extra").has_value());
  EXPECT_FALSE(parseFakenectName("").has_value());
  EXPECT_FALSE(parseFakenectName("d-abc-12.pgm").has_value());
  EXPECT_FALSE(parseFakenectName("d-1.0-.pgm").has_value());
  EXPECT_FALSE(parseFakenectName("d-1.0-99999999999.pgm").has_value());  // > 32 bits
}

TEST(FakenectDump, WriterProducesTheRecordLayout) {
  const fs::path dir = testing::scratchDir("fakenect_layout");
  const auto frames = testing::syntheticFrames(kSeed, 3);
  writeFakenectDump(dir, frames, FakenectWriteOptions{.first_device_ticks = 1000});
  const auto lines = readLines(dir / "INDEX.txt");
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[0], "d-1700000000.000000-1000.pgm");
  EXPECT_EQ(lines[1], "r-1700000000.000000-1000.ppm");
  EXPECT_EQ(lines[2], "d-1700000000.033333-2001000.pgm");  // 1/30 s = 2,000,000 ticks
  EXPECT_EQ(lines[5], "r-1700000000.066667-4001000.ppm");
  std::ifstream depth(dir / lines[0], std::ios::binary);
  std::string header;
  std::getline(depth, header);
  EXPECT_EQ(header, "P5 640 480 65535");
  EXPECT_EQ(fs::file_size(dir / lines[0]), header.size() + 1 + 640u * 480u * 2u);
  EXPECT_EQ(fs::file_size(dir / lines[1]),
            std::string("P6 640 480 255\n").size() + 640u * 480u * 3u);
  // Raw depth is little-endian 11-bit: every second byte is at most 0x07.
  std::string payload((std::istreambuf_iterator<char>(depth)), std::istreambuf_iterator<char>());
  for (std::size_t i = 1; i < payload.size(); i += 2)
    ASSERT_LE(static_cast<unsigned char>(payload[i]), 7u);
  EXPECT_TRUE(validateFakenectDump(dir).empty());
}

TEST(FakenectDump, RoundTripThroughOwnReaderIsWithinRawQuantisation) {
  const fs::path dir = testing::scratchDir("fakenect_round_trip");
  const auto rendered = testing::renderSyntheticSequence(kSeed, 6);
  std::vector<Frame> frames;
  for (const auto& r : rendered) frames.push_back(r.frame);
  // Start 2 frames before the 32-bit counter wraps.
  writeFakenectDump(dir, frames,
                    FakenectWriteOptions{.first_device_ticks = 0xFFFFFFFFu - 3'000'000});
  FakenectDumpSource source(dir, FakenectDumpOptions{.pacing = Pacing::kAsFastAsPossible});
  EXPECT_EQ(source.describe(), "fakenect:" + dir.string());
  EXPECT_EQ(source.depthCount(), frames.size());
  std::stop_source stop;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    SourceEvent event = source.next(stop.get_token());
    ASSERT_TRUE(std::holds_alternative<Frame>(event)) << "frame " << i;
    const Frame& frame = std::get<Frame>(event);
    EXPECT_EQ(frame.sequence, i);
    EXPECT_EQ(frame.intrinsics, frames[i].intrinsics);
    // Capture times are the device counter mapped against the recorded host times; with
    // exact recorded times that is the original stamp (to the microsecond of the file name).
    EXPECT_NEAR(static_cast<double>(frame.timestamp_ns - frames[i].timestamp_ns), 0.0, 2000.0);
    EXPECT_EQ(testing::compareThroughRawDisparity(frames[i].depth, frame.depth).violations, 0)
        << "frame " << i;
    EXPECT_EQ(cv::norm(frame.depth, frames[i].depth, cv::NORM_INF) > 0, true);  // quantised
    ASSERT_FALSE(frame.rgb.empty());
    EXPECT_EQ(cv::norm(frame.rgb, frames[i].rgb, cv::NORM_INF), 0.0);
    // Against the noise-free truth: within the sensor noise plus one raw step.
    const cv::Mat& ideal = rendered[i].truth.ideal_depth;
    double sum = 0;
    int n = 0;
    for (int y = 0; y < ideal.rows; y += 4) {
      for (int x = 0; x < ideal.cols; x += 4) {
        const double z = ideal.at<float>(y, x), got = frame.depth.at<std::uint16_t>(y, x) / 1000.0;
        if (z <= 0 || got <= 0) continue;
        sum += std::abs(got - z) / kinectRawDepthStep(z);
        ++n;
      }
    }
    ASSERT_GT(n, 1000);
    EXPECT_LT(sum / n, 2.0) << "mean error in raw steps, frame " << i;
  }
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

TEST(FakenectDump, DepthOnlyFramesAndPacing) {
  const fs::path dir = testing::scratchDir("fakenect_paced");
  auto frames = testing::syntheticFrames(kSeed, 4);
  for (auto& frame : frames) frame.rgb.release();
  writeFakenectDump(dir, frames);
  EXPECT_EQ(readLines(dir / "INDEX.txt").size(), 4u);
  FakenectDumpSource source(dir);  // paced at the recorded 30 Hz
  std::stop_source stop;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 4; ++i) {
    auto event = source.next(stop.get_token());
    ASSERT_TRUE(std::holds_alternative<Frame>(event));
    EXPECT_TRUE(std::get<Frame>(event).rgb.empty());
  }
  const auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_GE(elapsed, std::chrono::milliseconds(95));  // 3 periods
  stop.request_stop();
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

TEST(FakenectDump, RejectsWrongSizedFrames) {
  const fs::path dir = testing::scratchDir("fakenect_wrong_size");
  Frame frame;
  frame.depth = cv::Mat(240, 320, CV_16UC1, cv::Scalar(1000));
  FakenectDumpWriter writer(dir);
  EXPECT_THROW(writer.write(frame), std::invalid_argument);
}

class BrokenDump : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = testing::scratchDir(std::string("fakenect_broken_") +
                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    writeFakenectDump(dir, testing::syntheticFrames(kSeed, 3));
    lines = readLines(dir / "INDEX.txt");
  }
  fs::path dir;
  std::vector<std::string> lines;
};

TEST_F(BrokenDump, MissingIndexIsFatal) {
  fs::remove(dir / "INDEX.txt");
  EXPECT_THROW(FakenectDumpSource{dir}, std::runtime_error);
  const auto problems = validateFakenectDump(dir);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("INDEX.txt"), std::string::npos);
}

TEST_F(BrokenDump, TruncatedDepthIsReportedWithItsPathAndSkipped) {
  const fs::path bad = dir / lines[2];  // second depth file
  fs::resize_file(bad, 1000);
  const auto problems = validateFakenectDump(dir);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find(bad.string()), std::string::npos) << problems[0];
  EXPECT_NE(problems[0].find("payload"), std::string::npos) << problems[0];

  FakenectDumpSource source(dir, FakenectDumpOptions{.pacing = Pacing::kAsFastAsPossible});
  std::stop_source stop;
  EXPECT_TRUE(std::holds_alternative<Frame>(source.next(stop.get_token())));
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_NE(std::get<SourceError>(event).message.find(bad.string()), std::string::npos);
  auto third = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<Frame>(third));
  EXPECT_EQ(std::get<Frame>(third).sequence, 1u);
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

TEST_F(BrokenDump, BadHeaderMissingFileAndMalformedLineAreAllReported) {
  {
    std::ofstream out(dir / lines[1],
                      std::ios::binary | std::ios::trunc);  // RGB with a 2-line header
    out << "P6\n640 480 255\n" << std::string(640 * 480 * 3, 'x');
  }
  fs::remove(dir / lines[4]);
  {
    std::ofstream out(dir / "INDEX.txt", std::ios::app);
    out << "\nnot-a-frame\n";
  }
  const auto problems = validateFakenectDump(dir);
  ASSERT_EQ(problems.size(), 4u);
  EXPECT_NE(problems[0].find((dir / lines[1]).string()), std::string::npos) << problems[0];
  EXPECT_NE(problems[0].find("header"), std::string::npos) << problems[0];
  EXPECT_NE(problems[1].find((dir / lines[4]).string()), std::string::npos) << problems[1];
  EXPECT_NE(problems[1].find("missing"), std::string::npos) << problems[1];
  EXPECT_NE(problems[2].find("INDEX.txt:7"), std::string::npos) << problems[2];
  EXPECT_NE(problems[3].find("INDEX.txt:8"), std::string::npos) << problems[3];

  // The own reader goes on: malformed lines first, then frames (the missing depth is an error).
  FakenectDumpSource source(dir, FakenectDumpOptions{.pacing = Pacing::kAsFastAsPossible});
  std::stop_source stop;
  int frames = 0, errors = 0;
  for (;;) {
    auto event = source.next(stop.get_token());
    if (std::holds_alternative<EndOfStream>(event)) break;
    std::holds_alternative<Frame>(event) ? ++frames : ++errors;
  }
  EXPECT_EQ(frames, 2);
  EXPECT_EQ(errors, 4);  // two index lines, the missing depth, the bad colour image
}

TEST_F(BrokenDump, OutOfRangeRawValuesAreRejected) {
  const fs::path file = dir / lines[0];
  std::fstream io(file, std::ios::binary | std::ios::in | std::ios::out);
  io.seekp(static_cast<std::streamoff>(std::string("P5 640 480 65535\n").size()) + 2 * 10);
  const char big[2] = {static_cast<char>(0xFF), static_cast<char>(0x0F)};
  io.write(big, 2);
  io.close();
  try {
    readFakenectDepth(file);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("(10, 0)"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shapesense
