#include "shapesense/driver/tum_recording.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <variant>

#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/bounded_file.h"

namespace shapesense {
namespace {

// One "<seconds> <path>" line, or the reason it is not one.
std::variant<TumIndexEntry, std::string> parseIndexLine(std::string_view line) {
  if (line.size() > kMaxIndexLineBytes) {
    return "line of " + std::to_string(line.size()) + " bytes, longer than " +
           std::to_string(kMaxIndexLineBytes) + ": " + quoteExcerpt(line);
  }
  std::istringstream fields{std::string(line)};
  std::string stamp, path;
  fields >> stamp >> path;
  const auto ns = parseSecondsToNs(stamp);
  if (!ns || path.empty()) return "expected '<seconds> <path>', got " + quoteExcerpt(line);
  if (!isPlainRelativePath(path)) {
    return "the path " + quoteExcerpt(path) +
           " is not a plain path inside the recording (absolute, with '..' or control characters)";
  }
  return TumIndexEntry{*ns, stamp, path};
}

std::vector<TumIndexEntry> readIndexFile(const std::filesystem::path& file, bool in_time_order,
                                         std::vector<std::string>& problems) {
  return parseTumIndexText(readRegularFile(file, kMaxIndexFileBytes), file.string(), in_time_order,
                           problems);
}

}  // namespace

std::vector<TumIndexEntry> parseTumIndexText(std::string_view text, const std::string& label,
                                             bool in_time_order,
                                             std::vector<std::string>& problems) {
  std::vector<TumIndexEntry> entries;
  forEachLine(text, [&](std::string_view line, int number) {
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos || line[first] == '#') return;
    const std::string where = label + ":" + std::to_string(number) + ": ";
    auto parsed = parseIndexLine(line);
    if (auto* reason = std::get_if<std::string>(&parsed)) {
      problems.push_back(where + *reason);
      return;
    }
    auto& entry = std::get<TumIndexEntry>(parsed);
    if (in_time_order && !entries.empty() &&
        !stampFollows(entries.back().timestamp_ns, entry.timestamp_ns)) {
      problems.push_back(where + "stamp " + entry.seconds_text + " is not after the kept line's " +
                         entries.back().seconds_text +
                         " (time cannot go back or stand still); skipped");
      return;
    }
    entries.push_back(std::move(entry));
  });
  return entries;
}

TumIndex readTumIndex(const std::filesystem::path& dir) {
  if (!std::filesystem::is_directory(dir)) {
    throw std::runtime_error(dir.string() + ": no such recording directory");
  }
  const auto depth_file = dir / "depth.txt";
  std::error_code ec;
  if (!std::filesystem::exists(std::filesystem::symlink_status(depth_file, ec))) {
    throw std::runtime_error(depth_file.string() +
                             ": missing; a TUM recording lists its depth "
                             "images there");
  }
  TumIndex index;
  index.camera = readRecordingCamera(dir);
  index.depth = readIndexFile(depth_file, true, index.problems);
  if (std::filesystem::exists(std::filesystem::symlink_status(dir / "rgb.txt", ec))) {
    index.rgb = readIndexFile(dir / "rgb.txt", false, index.problems);
    std::stable_sort(index.rgb.begin(), index.rgb.end(),
                     [](const auto& a, const auto& b) { return a.timestamp_ns < b.timestamp_ns; });
  }
  return index;
}

TumRecordingWriter::TumRecordingWriter(const std::filesystem::path& dir,
                                       const RecordingCamera& camera)
    : dir_(dir), camera_(camera) {
  std::filesystem::create_directories(dir_ / "depth");
  std::filesystem::create_directories(dir_ / "rgb");
  writeRecordingCamera(dir_, camera_);
  depth_index_.open(dir_ / "depth.txt");
  rgb_index_.open(dir_ / "rgb.txt");
  if (!depth_index_ || !rgb_index_) throw std::runtime_error("cannot write into " + dir_.string());
  depth_index_ << "# depth maps\n# timestamp filename\n";
  rgb_index_ << "# color images\n# timestamp filename\n";
}

void TumRecordingWriter::write(const Frame& frame) {
  CV_Assert(frame.depth.type() == CV_16UC1);
  const std::string stamp = formatNsAsSeconds(frame.timestamp_ns, 6);
  const std::string depth_name = "depth/" + stamp + ".png";
  cv::Mat units;
  // Millimetres to recording units; saturates at 65535 units (13.1 m at 5000/m).
  frame.depth.convertTo(units, CV_16UC1, camera_.depth_scale / 1000.0);
  if (!cv::imwrite((dir_ / depth_name).string(), units)) {
    throw std::runtime_error("cannot write " + (dir_ / depth_name).string());
  }
  depth_index_ << stamp << ' ' << depth_name << '\n' << std::flush;
  if (!frame.rgb.empty()) {
    const std::string rgb_name = "rgb/" + stamp + ".png";
    if (!cv::imwrite((dir_ / rgb_name).string(), frame.rgb)) {
      throw std::runtime_error("cannot write " + (dir_ / rgb_name).string());
    }
    rgb_index_ << stamp << ' ' << rgb_name << '\n' << std::flush;
  }
  if (!depth_index_ || !rgb_index_)
    throw std::runtime_error("cannot append to the index files in " + dir_.string());
}

}  // namespace shapesense
