// TumRecordingWriter -> ReplaySource round trip: what is written replays bit-identical.

#include "shapesense/driver/tum_recording.h"

#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "recording_fixture.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/replay_source.h"
#include "test_paths.h"

namespace shapesense {
namespace {

bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  if (a.empty()) return true;
  cv::Mat diff;
  cv::compare(a.reshape(1), b.reshape(1), diff, cv::CMP_NE);
  return cv::countNonZero(diff) == 0;
}

cv::Mat depthMm(int width, int height, int seed, int max_mm) {
  cv::Mat mm(height, width, CV_16UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed) + 1);
  rng.fill(mm, cv::RNG::UNIFORM, 0, max_mm + 1);
  mm.at<std::uint16_t>(0, 0) = 0;
  mm.at<std::uint16_t>(0, 1) = static_cast<std::uint16_t>(max_mm);
  return mm;
}

std::vector<Frame> makeFrames(const CameraIntrinsics& k, int max_mm) {
  std::vector<Frame> frames;
  // Microsecond-exact stamps at epoch scale, 1/30 s apart, plus one with a 7 s gap.
  const TimestampNs stamps[] = {1700000000033333000LL, 1700000000066667000LL, 1700000000100000000LL,
                                1700000000133333000LL, 1700000007000001000LL};
  std::uint64_t sequence = 0;
  for (TimestampNs t : stamps) {
    Frame f;
    f.intrinsics = k;
    f.timestamp_ns = t;
    f.sequence = sequence;
    f.depth = depthMm(k.width, k.height, static_cast<int>(sequence), max_mm);
    if (sequence != 2) {  // frame 2 has no colour
      f.rgb.create(k.height, k.width, CV_8UC3);
      cv::RNG rng(100 + sequence);
      rng.fill(f.rgb, cv::RNG::UNIFORM, 0, 256);
    }
    frames.push_back(f);
    ++sequence;
  }
  return frames;
}

void roundTrip(const std::string& name, const RecordingCamera& camera, int max_mm) {
  const auto dir = testing::scratchDir(name) / "recording";
  const std::vector<Frame> written = makeFrames(camera.intrinsics, max_mm);
  {
    TumRecordingWriter writer(dir, camera);
    EXPECT_EQ(writer.directory(), dir);
    for (const Frame& f : written) writer.write(f);
  }

  const RecordingCamera read_camera = readRecordingCamera(dir);
  EXPECT_EQ(read_camera.intrinsics, camera.intrinsics);
  EXPECT_EQ(read_camera.depth_scale, camera.depth_scale);

  const TumIndex index = readTumIndex(dir);
  EXPECT_TRUE(index.problems.empty());
  ASSERT_EQ(index.depth.size(), written.size());
  EXPECT_EQ(index.rgb.size(), written.size() - 1);
  for (std::size_t i = 0; i < written.size(); ++i) {
    EXPECT_EQ(index.depth[i].seconds_text, formatNsAsSeconds(written[i].timestamp_ns, 6));
  }

  ReplaySource source(dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible});
  ASSERT_EQ(source.frameCount(), written.size());
  std::stop_source stop;
  for (std::size_t i = 0; i < written.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    SourceEvent event = source.next(stop.get_token());
    ASSERT_TRUE(std::holds_alternative<Frame>(event))
        << (std::holds_alternative<SourceError>(event) ? std::get<SourceError>(event).message
                                                       : "EndOfStream");
    const Frame& replayed = std::get<Frame>(event);
    EXPECT_EQ(replayed.timestamp_ns, written[i].timestamp_ns);
    EXPECT_EQ(replayed.sequence, written[i].sequence);
    EXPECT_EQ(replayed.intrinsics, written[i].intrinsics);
    EXPECT_TRUE(identical(replayed.depth, written[i].depth)) << "depth differs";
    EXPECT_TRUE(identical(replayed.rgb, written[i].rgb))
        << "rgb differs (empty: " << replayed.rgb.empty() << ")";
  }
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

TEST(TumRecording, RoundTripIsBitIdenticalAtFiveThousandUnitsPerMetre) {
  RecordingCamera camera;
  camera.intrinsics = CameraIntrinsics{517.3, 516.5, 31.86, 25.53, 64, 48};
  // 13107 mm is the most 5000 units/m can hold in 16 bits.
  roundTrip("tum_roundtrip_5000", camera, 13107);
}

TEST(TumRecording, RoundTripIsBitIdenticalInMillimetreUnits) {
  RecordingCamera camera;
  camera.intrinsics = CameraIntrinsics{100.125, 99.875, 15.5, 11.25, 32, 24};
  camera.depth_scale = 1000.0;
  roundTrip("tum_roundtrip_1000", camera, 65535);
}

TEST(TumRecording, NonMicrosecondStampsReplayRoundedToTheMicrosecond) {
  const auto dir = testing::scratchDir("tum_rounding") / "recording";
  RecordingCamera camera;
  camera.intrinsics = CameraIntrinsics{525.0, 525.0, 1.5, 1.0, 4, 3};
  {
    TumRecordingWriter writer(dir, camera);
    Frame f;
    f.intrinsics = camera.intrinsics;
    f.depth = cv::Mat(3, 4, CV_16UC1, cv::Scalar(1234));
    f.timestamp_ns = 1700000000033333333LL;
    writer.write(f);
    f.timestamp_ns = 1700000000066666667LL;
    writer.write(f);
  }
  ReplaySource source(dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible});
  std::stop_source stop;
  auto a = source.next(stop.get_token());
  auto b = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<Frame>(a));
  ASSERT_TRUE(std::holds_alternative<Frame>(b));
  EXPECT_EQ(std::get<Frame>(a).timestamp_ns, 1700000000033333000LL);
  EXPECT_EQ(std::get<Frame>(b).timestamp_ns, 1700000000066667000LL);
  EXPECT_TRUE(std::filesystem::exists(dir / "depth" / "1700000000.033333.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "depth" / "1700000000.066667.png"));
  EXPECT_TRUE(std::get<Frame>(a).rgb.empty());
}

TEST(TumRecording, WriterRejectsANonDepthImage) {
  const auto dir = testing::scratchDir("tum_writer_bad") / "recording";
  TumRecordingWriter writer(dir, RecordingCamera{});
  Frame f;
  f.depth = cv::Mat(3, 4, CV_32FC1, cv::Scalar(1.0));
  EXPECT_ANY_THROW(writer.write(f));
}

}  // namespace
}  // namespace shapesense
