#pragma once
// Fakenect dumps: the recording format of libfreenect's `record` tool and the input of its
// `fakenect` replay library. A dump directory holds
//   INDEX.txt                     one file name per line, in delivery order
//   d-<host s>-<device ts>.pgm    "P5 640 480 65535\n" + 640*480 raw 11-bit depth values,
//                                 uint16 little-endian (2047 = no reading)
//   r-<host s>-<device ts>.ppm    "P6 640 480 255\n" + 640*480 RGB triplets
//   a-<host s>-<device ts>.dump   accelerometer state (ignored here)
// <host s> is the host time of arrival in seconds ("%f", 6 decimals), <device ts> the 32-bit
// 60 MHz device counter of the frame. Only the "<type>-<host s>-<device ts>" front of a name
// is meaningful.
//
// Depth is converted between millimetres and raw with kinect_raw.h (default params unless
// given); the mm -> raw -> mm round trip loses at most half a raw step (z^2 * 0.0031 / 2 m:
// 1.6 mm at 1 m, 14 mm at 3 m, 31 mm at 4.5 m) plus 0.5 mm.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "shapesense/core/geometry/frame.h"
#include "shapesense/driver/device_clock.h"
#include "shapesense/driver/frame_source.h"
#include "shapesense/driver/kinect_raw.h"

namespace shapesense {

inline constexpr int kFakenectWidth = 640;
inline constexpr int kFakenectHeight = 480;
/// INDEX.txt is read as untrusted input (see bounded_file.h): at most this large, names at most
/// this long, and inside the dump directory.
inline constexpr std::size_t kMaxFakenectIndexBytes = 64 * 1024 * 1024;
inline constexpr std::size_t kMaxFakenectLineBytes = 4096;

/// One INDEX.txt line.
struct FakenectIndexEntry {
  char type = 0;                   ///< 'd' depth, 'r' RGB, 'a' accelerometer, other: unknown
  TimestampNs host_ns = 0;         ///< arrival time written by the recorder (host seconds)
  std::uint32_t device_ticks = 0;  ///< 60 MHz device counter
  std::string file_name;           ///< as written in INDEX.txt, relative to the dump directory
  int line = 0;                    ///< 1-based line number in INDEX.txt
};

/// Parses "<type>-<seconds>-<ticks>..." (the same fields fakenect's sscanf reads).
std::optional<FakenectIndexEntry> parseFakenectName(const std::string& name);

struct FakenectIndex {
  std::vector<FakenectIndexEntry> entries;  ///< well-formed lines, in file order
  std::vector<std::string> problems;        ///< malformed lines, with path and line number
};

/// Reads dir/INDEX.txt. Throws std::runtime_error when it cannot be opened, is not a regular
/// file or is larger than kMaxFakenectIndexBytes. Names that are absolute or climb out with
/// ".." are problems.
FakenectIndex readFakenectIndex(const std::filesystem::path& dir);
/// Parses the text of an INDEX.txt (`label` names it in problems).
FakenectIndex parseFakenectIndexText(std::string_view text, const std::string& label);

/// Every reason Debian's fakenect library would exit() or misbehave on this dump: missing or
/// unreadable INDEX.txt, empty or malformed lines (an empty line ends fakenect's replay), files
/// that do not exist, depth/RGB files whose header is not one line or whose payload is shorter
/// than 640x480. Empty result = safe to hand to fakenect. Messages name the path.
std::vector<std::string> validateFakenectDump(const std::filesystem::path& dir);

/// Reads one depth file: returns CV_16UC1 raw 640x480, or throws std::runtime_error naming the
/// path (unreadable, wrong header, short payload, values above 2047).
cv::Mat readFakenectDepth(const std::filesystem::path& file);
/// Reads one RGB file: returns CV_8UC3 BGR 640x480, or throws std::runtime_error naming the path.
cv::Mat readFakenectRgb(const std::filesystem::path& file);
/// The same from a file's bytes; `label` names it in errors.
cv::Mat decodeFakenectDepth(std::string_view data, const std::string& label);
cv::Mat decodeFakenectRgb(std::string_view data, const std::string& label);

struct FakenectWriteOptions {
  KinectRawParams raw{};  ///< mm -> raw conversion. Default: kinect_raw.h defaults.
  /// Device counter of the first frame; later frames add (t - t0) * 60 MHz, modulo 2^32.
  /// Default 0. Set it near 2^32 to put a counter wrap into the dump.
  std::uint32_t first_device_ticks = 0;
};

/// Appends frames to a dump directory (created if needed), keeping INDEX.txt in step.
/// Frames must be 640x480 (fakenect serves only that size).
class FakenectDumpWriter {
 public:
  explicit FakenectDumpWriter(const std::filesystem::path& dir, FakenectWriteOptions options = {});

  /// Writes the depth (and the RGB when present) of a frame, named after its timestamp.
  /// Throws std::invalid_argument on a wrong size/type, std::runtime_error on I/O errors.
  void write(const Frame& frame);

  const std::filesystem::path& directory() const { return dir_; }

 private:
  void appendIndex(const std::string& name);

  std::filesystem::path dir_;
  FakenectWriteOptions options_;
  std::ofstream index_;
  std::optional<TimestampNs> first_ns_;
};

/// Writes all frames with one FakenectDumpWriter.
void writeFakenectDump(const std::filesystem::path& dir, std::span<const Frame> frames,
                       const FakenectWriteOptions& options = {});

struct FakenectDumpOptions {
  KinectRawParams raw{};              ///< raw -> mm conversion. Default: kinect_raw.h defaults.
  Pacing pacing = Pacing::kRecorded;  ///< kRecorded sleeps to the recorded host times.
  /// A colour image is paired with a depth image when their device times differ by at most
  /// this. Default 20 ms (the Kinect's streams are not synchronised: up to half a period).
  std::chrono::milliseconds max_rgb_offset{20};
  DeviceClockParams clock{};      ///< maps device counters to capture times.
  CameraIntrinsics intrinsics{};  ///< Kinect v1 defaults.
};

/// Replays a fakenect dump with this project's own reader (no libfreenect involved).
/// Frame timestamps are the device counters mapped through DeviceClock against the recorded
/// host times, i.e. what FreenectSource would have stamped live.
class FakenectDumpSource final : public FrameSource {
 public:
  /// Reads INDEX.txt; throws std::runtime_error when it is missing or lists no depth file.
  explicit FakenectDumpSource(std::filesystem::path dir, FakenectDumpOptions options = {});

  /// "fakenect:<dir>".
  std::string describe() const override;

  /// The next depth frame (paired with the nearest colour image). A malformed index line or a
  /// bad file is reported as SourceError naming the path, and the replay moves on.
  SourceEvent next(std::stop_token stop) override;

  std::size_t depthCount() const { return depth_.size(); }

 private:
  struct Stamped {
    FakenectIndexEntry entry;
    TimestampNs capture_ns = 0;
  };
  const Stamped* nearestRgb(const Stamped& depth) const;
  bool waitUntil(TimestampNs host_ns, std::stop_token& stop);

  std::filesystem::path dir_;
  FakenectDumpOptions options_;
  KinectRawToMm to_mm_;
  std::vector<Stamped> depth_;
  std::vector<Stamped> rgb_;
  std::deque<std::string> problems_;
  std::size_t position_ = 0;
  std::uint64_t sequence_ = 0;
  std::optional<std::chrono::steady_clock::time_point> wall_start_;
  std::mutex wait_mutex_;  ///< only for the stop-aware sleep
  std::condition_variable_any wait_cv_;
};

}  // namespace shapesense
