#pragma once
// Builds small TUM-layout recordings in scratch directories for driver, daemon and CLI tests.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/frame.h"

namespace shapesense::testing {

/// Writes `text` to `path` verbatim (binary mode, so "\r\n" stays as written).
void writeTextFile(const std::filesystem::path& path, const std::string& text);

/// Writes an image with cv::imwrite; fails the current test (ADD_FAILURE) when it cannot.
void writePng(const std::filesystem::path& path, const cv::Mat& image);

/// Cuts a file down to its first `keep_bytes` bytes.
void truncateFile(const std::filesystem::path& path, std::uintmax_t keep_bytes);

/// A CV_16UC1 image of recording units whose values are all multiples of 5 (so they convert
/// to whole millimetres at 5000 units/m), with a few zero (no reading) pixels. `seed` varies it.
cv::Mat patternDepthUnits(int width, int height, int seed);

/// A CV_8UC3 BGR image that differs per pixel and per `seed`.
cv::Mat patternBgr(int width, int height, int seed);

/// Accumulates the files of a recording and writes the index files on finish().
class RecordingBuilder {
 public:
  /// `dir` must exist (e.g. scratchDir()); depth/ and rgb/ are created in it.
  RecordingBuilder(std::filesystem::path dir, int width = 8, int height = 6);

  int width() const { return width_; }
  int height() const { return height_; }
  const std::filesystem::path& dir() const { return dir_; }

  /// Writes depth/<stamp>.png (the pattern for `seed` when `units` is empty) and lists it in
  /// depth.txt. Returns the units written.
  cv::Mat addDepth(const std::string& stamp, int seed = 0, cv::Mat units = {});
  /// Lists depth/<stamp>.png in depth.txt without writing the file.
  void listDepthOnly(const std::string& stamp);
  /// Writes rgb/<stamp>.png and lists it in rgb.txt. Returns the image written.
  cv::Mat addRgb(const std::string& stamp, int seed = 0, cv::Mat bgr = {});
  /// Appends a raw line (without the newline) to depth.txt / rgb.txt.
  void rawDepthLine(const std::string& line) { depth_lines_.push_back(line); }
  void rawRgbLine(const std::string& line) { rgb_lines_.push_back(line); }

  /// camera.json: by default intrinsics matching the image size at `depth_scale` (the principal
  /// point at the image centre).
  void writeCamera(double depth_scale = 5000.0, double fx = 100.0, double fy = 101.0,
                   std::optional<double> cx = std::nullopt,
                   std::optional<double> cy = std::nullopt);
  /// camera.json with arbitrary text.
  void writeCameraText(const std::string& text);

  /// Writes depth.txt (and rgb.txt when any RGB line was added) with `newline` line endings.
  void finish(const std::string& newline = "\n");

  /// depth/<stamp>.png
  std::filesystem::path depthPath(const std::string& stamp) const;

 private:
  std::filesystem::path dir_;
  int width_;
  int height_;
  std::vector<std::string> depth_lines_;
  std::vector<std::string> rgb_lines_;
};

/// A complete small recording of `frames` depth+RGB frames 1/30 s apart starting at
/// 1600000000.000000 (stamps with 6 decimals), with camera.json. Returns its directory.
std::filesystem::path makeSmallRecording(const std::string& scratch_name, int frames, int width = 8,
                                         int height = 6);

/// The stamp text of frame i of makeSmallRecording: "1600000000.000000", "1600000000.033333", ...
std::string smallRecordingStamp(int i);

/// Every frame of the recording in `dir`, replayed as fast as possible. A replay error fails
/// the current test (ADD_FAILURE) and the frame is left out.
std::vector<Frame> replayAll(const std::filesystem::path& dir);

/// A replayed frame equals the one recorded: stamp `expected_stamp`, depth and RGB bit for
/// bit, and `camera` as intrinsics (camera.json holds one camera: the first recorded frame's).
void expectSameFrame(const Frame& replayed, const Frame& original, TimestampNs expected_stamp,
                     const CameraIntrinsics& camera);

/// Copies a directory tree (e.g. a shared real recording into a scratch dir).
void copyRecording(const std::filesystem::path& from, const std::filesystem::path& to);

}  // namespace shapesense::testing
