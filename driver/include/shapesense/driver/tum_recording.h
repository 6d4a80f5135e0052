#pragma once
// Recordings in the TUM RGB-D layout: `depth.txt` and `rgb.txt` index files ("<seconds>
// <relative path>" per line, '#' comments), 16-bit PNG depth at `depth_scale` units per metre
// (5000 by default, 0 = no reading), 8-bit colour PNG, and an optional camera.json.
//
// Recordings are read as untrusted input (see bounded_file.h): index files of at most
// kMaxIndexFileBytes with lines of at most kMaxIndexLineBytes, listed paths relative and inside
// the recording (a line naming /etc/passwd or ../x is a problem, not a file to open).

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shapesense/core/geometry/frame.h"
#include "shapesense/driver/camera_file.h"

namespace shapesense {

/// 1.4 million frames, 13 hours at 30 frames per second.
inline constexpr std::size_t kMaxIndexFileBytes = 64 * 1024 * 1024;
/// A TUM line is ~50 bytes; a path is at most PATH_MAX.
inline constexpr std::size_t kMaxIndexLineBytes = 4096;

/// One line of depth.txt or rgb.txt.
struct TumIndexEntry {
  TimestampNs timestamp_ns = 0;
  std::string seconds_text;             ///< the stamp exactly as written
  std::filesystem::path relative_path;  ///< relative to the recording directory
};

/// Parsed depth.txt / rgb.txt of a recording. Malformed lines are reported in `problems`
/// (with file and line number) and skipped, and so are depth lines not stamped after the last
/// kept depth line (stampFollows, core/timestamp.h, the daemon cache's rule): time never goes
/// back or stands still in a replay, so the daemon and `shapesense analyze` see the same frames.
struct TumIndex {
  RecordingCamera camera;
  std::vector<TumIndexEntry> depth;  ///< in file order
  std::vector<TumIndexEntry> rgb;    ///< sorted by time
  std::vector<std::string> problems;
};

/// Reads the index files and camera.json of `dir`. Throws std::runtime_error when the
/// directory or its depth.txt is missing or unreadable (not a regular file, past its size
/// limit; rgb.txt is optional), or camera.json is malformed.
TumIndex readTumIndex(const std::filesystem::path& dir);

/// Parses the text of an index file (`label` names it in problems). With `in_time_order`,
/// lines not stamped after the latest kept line are problems too.
std::vector<TumIndexEntry> parseTumIndexText(std::string_view text, const std::string& label,
                                             bool in_time_order,
                                             std::vector<std::string>& problems);

/// Appends frames to a recording directory in the TUM layout. File names are the capture time
/// in seconds with 6 decimals, so a recording replays with the same stamps (to the microsecond).
class TumRecordingWriter {
 public:
  /// Creates `dir` (and depth/, rgb/) and writes camera.json.
  TumRecordingWriter(const std::filesystem::path& dir, const RecordingCamera& camera);

  /// Writes the frame's depth (and RGB when present). Throws std::runtime_error on I/O errors.
  void write(const Frame& frame);

  const std::filesystem::path& directory() const { return dir_; }

 private:
  std::filesystem::path dir_;
  RecordingCamera camera_;
  std::ofstream depth_index_;
  std::ofstream rgb_index_;
};

}  // namespace shapesense
