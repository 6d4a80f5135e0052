#include "shapesense/driver/tum_recording.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/timestamp.h"

namespace shapesense {
namespace {

// Reads "<seconds> <path>" lines; '#' starts a comment line.
std::vector<TumIndexEntry> readIndexFile(const std::filesystem::path& file,
                                         std::vector<std::string>& problems) {
  std::vector<TumIndexEntry> entries;
  std::ifstream in(file);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, path;
    fields >> stamp >> path;
    const auto ns = parseSecondsToNs(stamp);
    if (!ns || path.empty()) {
      problems.push_back(file.string() + ":" + std::to_string(line_number) +
                         ": expected '<seconds> <path>', got '" + line + "'");
      continue;
    }
    entries.push_back({*ns, stamp, path});
  }
  return entries;
}

}  // namespace

TumIndex readTumIndex(const std::filesystem::path& dir) {
  if (!std::filesystem::is_directory(dir)) {
    throw std::runtime_error(dir.string() + ": no such recording directory");
  }
  const auto depth_file = dir / "depth.txt";
  if (!std::filesystem::exists(depth_file)) {
    throw std::runtime_error(depth_file.string() +
                             ": missing; a TUM recording lists its depth "
                             "images there");
  }
  TumIndex index;
  index.camera = readRecordingCamera(dir);
  index.depth = readIndexFile(depth_file, index.problems);
  if (std::filesystem::exists(dir / "rgb.txt")) {
    index.rgb = readIndexFile(dir / "rgb.txt", index.problems);
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
