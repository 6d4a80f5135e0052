#include "recording_fixture.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/replay_source.h"

namespace shapesense::testing {

void writeTextFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) ADD_FAILURE() << "cannot write " << path;
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
  std::filesystem::create_directories(path.parent_path());
  if (!cv::imwrite(path.string(), image)) ADD_FAILURE() << "cv::imwrite failed for " << path;
}

void truncateFile(const std::filesystem::path& path, std::uintmax_t keep_bytes) {
  std::filesystem::resize_file(path, keep_bytes);
}

cv::Mat patternDepthUnits(int width, int height, int seed) {
  cv::Mat units(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int mm = 400 + (7 * u + 131 * v + 17 * seed) % 9000;
      units.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(5 * mm);
    }
  }
  units.at<std::uint16_t>(0, 0) = 0;
  units.at<std::uint16_t>(height - 1, width - 1) = 0;
  return units;
}

cv::Mat patternBgr(int width, int height, int seed) {
  cv::Mat bgr(height, width, CV_8UC3);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      bgr.at<cv::Vec3b>(v, u) =
          cv::Vec3b(static_cast<uchar>(10 * u + seed), static_cast<uchar>(20 * v + 3 * seed),
                    static_cast<uchar>(255 - u - v - seed));
    }
  }
  return bgr;
}

RecordingBuilder::RecordingBuilder(std::filesystem::path dir, int width, int height)
    : dir_(std::move(dir)), width_(width), height_(height) {
  std::filesystem::create_directories(dir_ / "depth");
  std::filesystem::create_directories(dir_ / "rgb");
}

std::filesystem::path RecordingBuilder::depthPath(const std::string& stamp) const {
  return dir_ / "depth" / (stamp + ".png");
}

cv::Mat RecordingBuilder::addDepth(const std::string& stamp, int seed, cv::Mat units) {
  if (units.empty()) units = patternDepthUnits(width_, height_, seed);
  writePng(depthPath(stamp), units);
  listDepthOnly(stamp);
  return units;
}

void RecordingBuilder::listDepthOnly(const std::string& stamp) {
  depth_lines_.push_back(stamp + " depth/" + stamp + ".png");
}

cv::Mat RecordingBuilder::addRgb(const std::string& stamp, int seed, cv::Mat bgr) {
  if (bgr.empty()) bgr = patternBgr(width_, height_, seed);
  writePng(dir_ / "rgb" / (stamp + ".png"), bgr);
  rgb_lines_.push_back(stamp + " rgb/" + stamp + ".png");
  return bgr;
}

void RecordingBuilder::writeCamera(double depth_scale, double fx, double fy,
                                   std::optional<double> cx, std::optional<double> cy) {
  const double centre_x = cx.value_or(0.5 * (width_ - 1));
  const double centre_y = cy.value_or(0.5 * (height_ - 1));
  writeTextFile(
      dir_ / "camera.json",
      "{\"fx\": " + std::to_string(fx) + ", \"fy\": " + std::to_string(fy) +
          ", \"cx\": " + std::to_string(centre_x) + ", \"cy\": " + std::to_string(centre_y) +
          ", \"width\": " + std::to_string(width_) + ", \"height\": " + std::to_string(height_) +
          ", \"depth_scale\": " + std::to_string(depth_scale) + "}\n");
}

void RecordingBuilder::writeCameraText(const std::string& text) {
  writeTextFile(dir_ / "camera.json", text);
}

void RecordingBuilder::finish(const std::string& newline) {
  std::string depth = "# depth maps" + newline + "# timestamp filename" + newline;
  for (const auto& line : depth_lines_) depth += line + newline;
  writeTextFile(dir_ / "depth.txt", depth);
  if (!rgb_lines_.empty()) {
    std::string rgb = "# color images" + newline;
    for (const auto& line : rgb_lines_) rgb += line + newline;
    writeTextFile(dir_ / "rgb.txt", rgb);
  }
}

std::string smallRecordingStamp(int i) {
  // 1/30 s spacing rounded to the microsecond, as TUM recordings write it.
  const TimestampNs ns =
      1'600'000'000'000'000'000LL + (static_cast<TimestampNs>(i) * 1'000'000'000LL) / 30;
  return formatNsAsSeconds(ns, 6);
}

std::filesystem::path makeSmallRecording(const std::string& scratch_name, int frames, int width,
                                         int height) {
  const auto dir = std::filesystem::path(SHAPESENSE_BINARY_DIR) / "test-scratch" / scratch_name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  RecordingBuilder builder(dir, width, height);
  builder.writeCamera();
  for (int i = 0; i < frames; ++i) {
    builder.addDepth(smallRecordingStamp(i), i);
    builder.addRgb(smallRecordingStamp(i), i);
  }
  builder.finish();
  return dir;
}

void copyRecording(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::filesystem::create_directories(to);
  std::filesystem::copy(
      from, to,
      std::filesystem::copy_options::recursive | std::filesystem::copy_options::overwrite_existing);
}

std::vector<Frame> replayAll(const std::filesystem::path& dir) {
  ReplaySource replay(dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible});
  std::vector<Frame> frames;
  std::stop_source stop;
  while (true) {
    SourceEvent event = replay.next(stop.get_token());
    if (std::holds_alternative<EndOfStream>(event)) break;
    if (auto* error = std::get_if<SourceError>(&event)) {
      ADD_FAILURE() << "replaying " << dir << ": " << error->message;
      continue;
    }
    frames.push_back(std::move(std::get<Frame>(event)));
  }
  return frames;
}

void expectSameFrame(const Frame& replayed, const Frame& original, TimestampNs expected_stamp,
                     const CameraIntrinsics& camera) {
  EXPECT_EQ(replayed.timestamp_ns, expected_stamp);
  ASSERT_EQ(replayed.depth.type(), CV_16UC1);
  ASSERT_EQ(replayed.depth.size(), original.depth.size());
  EXPECT_EQ(cv::norm(replayed.depth, original.depth, cv::NORM_INF), 0.0);
  ASSERT_EQ(replayed.rgb.empty(), original.rgb.empty());
  if (!original.rgb.empty()) {
    EXPECT_EQ(cv::norm(replayed.rgb, original.rgb, cv::NORM_INF), 0.0);
  }
  EXPECT_EQ(replayed.intrinsics.fx, camera.fx);
  EXPECT_EQ(replayed.intrinsics.fy, camera.fy);
  EXPECT_EQ(replayed.intrinsics.cx, camera.cx);
  EXPECT_EQ(replayed.intrinsics.cy, camera.cy);
  EXPECT_EQ(replayed.intrinsics.width, camera.width);
  EXPECT_EQ(replayed.intrinsics.height, camera.height);
}

}  // namespace shapesense::testing
