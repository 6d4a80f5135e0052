#include "shapesense/driver/fakenect_dump.h"

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/bounded_file.h"

namespace shapesense {
namespace fs = std::filesystem;
namespace {

constexpr std::size_t kDepthBytes = std::size_t{kFakenectWidth} * kFakenectHeight * 2;
constexpr std::size_t kRgbBytes = std::size_t{kFakenectWidth} * kFakenectHeight * 3;
constexpr double kDeviceTicksPerNs = 60e6 / 1e9;

// A frame file is its header line and payload; anything much larger is not one.
constexpr std::size_t kHeaderSlack = 4096;

/// Splits "P5 640 480 65535\n<payload>"; checks the header and the payload size.
std::string_view payloadOf(std::string_view data, const std::string& label, const char* magic,
                           int maxval, std::size_t bytes) {
  const auto newline = data.find('\n');
  if (newline == std::string::npos) {
    throw std::runtime_error(label + ": no header line");
  }
  std::istringstream header{std::string(data.substr(0, std::min(newline, kHeaderSlack)))};
  std::string got_magic;
  int width = 0, height = 0, got_max = 0;
  header >> got_magic >> width >> height >> got_max;
  if (!header || got_magic != magic || width != kFakenectWidth || height != kFakenectHeight ||
      got_max != maxval) {
    throw std::runtime_error(label + ": header " + quoteExcerpt(data.substr(0, newline)) +
                             " is not '" + magic + " 640 480 " + std::to_string(maxval) +
                             "' on one line");
  }
  const std::size_t available = data.size() - newline - 1;
  if (available < bytes) {
    throw std::runtime_error(label + ": payload has " + std::to_string(available) +
                             " bytes, expected " + std::to_string(bytes));
  }
  return data.substr(newline + 1, bytes);
}

// A malformed INDEX.txt line, quoted short and escaped.
std::string malformedLine(const std::string& where, std::string_view line) {
  return where + ": malformed line " + quoteExcerpt(line);
}

void writeFileOrThrow(const fs::path& file, const std::string& header, const std::string& payload) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << header;
  out.write(payload.data(), static_cast<std::streamsize>(payload.size()));
  out.close();
  if (!out) throw std::runtime_error(file.string() + ": write failed");
}

}  // namespace

std::optional<FakenectIndexEntry> parseFakenectName(const std::string& name) {
  // "<c>-<seconds>-<ticks><anything>"
  if (name.size() < 5 || name[1] != '-') return std::nullopt;
  const auto dash = name.find('-', 2);
  if (dash == std::string::npos) return std::nullopt;
  const auto host_ns = parseSecondsToNs(std::string_view(name).substr(2, dash - 2));
  if (!host_ns) return std::nullopt;
  std::size_t end = dash + 1;
  while (end < name.size() && name[end] >= '0' && name[end] <= '9') ++end;
  if (end == dash + 1 || end - dash - 1 > 10) return std::nullopt;
  const std::uint64_t ticks = std::stoull(name.substr(dash + 1, end - dash - 1));
  if (ticks > 0xFFFFFFFFull) return std::nullopt;
  FakenectIndexEntry entry;
  entry.type = name[0];
  entry.host_ns = *host_ns;
  entry.device_ticks = static_cast<std::uint32_t>(ticks);
  entry.file_name = name;
  return entry;
}

FakenectIndex parseFakenectIndexText(std::string_view text, const std::string& label) {
  FakenectIndex index;
  forEachLine(text, [&](std::string_view line, int number) {
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::string where = label + ":" + std::to_string(number);
    auto entry =
        line.size() <= kMaxFakenectLineBytes ? parseFakenectName(std::string(line)) : std::nullopt;
    if (!entry) {
      index.problems.push_back(malformedLine(where, line));
      return;
    }
    if (!isPlainRelativePath(entry->file_name)) {
      index.problems.push_back(
          where + ": " + quoteExcerpt(line) +
          " is not a plain path inside the dump (absolute, with '..' or control characters)");
      return;
    }
    entry->line = number;
    index.entries.push_back(std::move(*entry));
  });
  return index;
}

FakenectIndex readFakenectIndex(const fs::path& dir) {
  const fs::path index_path = dir / "INDEX.txt";
  return parseFakenectIndexText(readRegularFile(index_path, kMaxFakenectIndexBytes),
                                index_path.string());
}

std::vector<std::string> validateFakenectDump(const fs::path& dir) {
  std::vector<std::string> problems;
  const fs::path index_path = dir / "INDEX.txt";
  std::string text;
  try {
    text = readRegularFile(index_path, kMaxFakenectIndexBytes);
  } catch (const InputFileError& e) {
    return {e.what()};
  }
  int lines = 0;
  bool any_depth = false;
  forEachLine(text, [&](std::string_view line, int number) {
    lines = number;
    const std::string where = index_path.string() + ":" + std::to_string(number);
    // fakenect reads up to '\n' and treats an empty line as the end of the dump.
    const auto entry = line.empty() || line.size() > kMaxFakenectLineBytes
                           ? std::nullopt
                           : parseFakenectName(std::string(line));
    if (!entry) {
      problems.push_back(malformedLine(where, line));
      return;
    }
    try {
      const fs::path file = pathInside(dir, entry->file_name);
      std::error_code ec;
      if (!fs::exists(fs::symlink_status(file, ec))) {
        problems.push_back(file.string() + ": missing (listed at " + where + ")");
        return;
      }
      if (entry->type == 'd') {
        readFakenectDepth(file);
        any_depth = true;
      } else if (entry->type == 'r') {
        readFakenectRgb(file);
      } else if (!fs::is_regular_file(file, ec)) {
        problems.push_back(file.string() + ": not a regular file (listed at " + where + ")");
      }
    } catch (const std::exception& e) {
      problems.push_back(e.what());
    }
  });
  if (lines == 0)
    problems.push_back(index_path.string() + ": empty");
  else if (!any_depth && problems.empty())
    problems.push_back(index_path.string() + ": no depth file");
  return problems;
}

cv::Mat readFakenectDepth(const fs::path& file) {
  return decodeFakenectDepth(readRegularFile(file, kDepthBytes + kHeaderSlack), file.string());
}

cv::Mat readFakenectRgb(const fs::path& file) {
  return decodeFakenectRgb(readRegularFile(file, kRgbBytes + kHeaderSlack), file.string());
}

cv::Mat decodeFakenectDepth(std::string_view data, const std::string& label) {
  const auto payload = payloadOf(data, label, "P5", 65535, kDepthBytes);
  cv::Mat raw(kFakenectHeight, kFakenectWidth, CV_16UC1);
  const auto* bytes = reinterpret_cast<const unsigned char*>(payload.data());
  for (int y = 0; y < raw.rows; ++y) {
    auto* row = raw.ptr<std::uint16_t>(y);
    for (int x = 0; x < raw.cols; ++x) {
      const std::size_t i = 2 * (static_cast<std::size_t>(y) * kFakenectWidth + x);
      const auto value = static_cast<std::uint16_t>(bytes[i] | (bytes[i + 1] << 8));
      if (value > kKinectRawNoReading) {
        throw std::runtime_error(label + ": pixel (" + std::to_string(x) + ", " +
                                 std::to_string(y) + ") = " + std::to_string(value) +
                                 " is not an 11-bit value");
      }
      row[x] = value;
    }
  }
  return raw;
}

cv::Mat decodeFakenectRgb(std::string_view data, const std::string& label) {
  const auto payload = payloadOf(data, label, "P6", 255, kRgbBytes);
  const cv::Mat rgb(kFakenectHeight, kFakenectWidth, CV_8UC3, const_cast<char*>(payload.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

FakenectDumpWriter::FakenectDumpWriter(const fs::path& dir, FakenectWriteOptions options)
    : dir_(dir), options_(options) {
  fs::create_directories(dir_);
  index_.open(dir_ / "INDEX.txt", std::ios::app);
  if (!index_)
    throw std::runtime_error((dir_ / "INDEX.txt").string() + ": cannot open for writing");
}

void FakenectDumpWriter::appendIndex(const std::string& name) {
  index_ << name << '\n';
  index_.flush();
  if (!index_) throw std::runtime_error((dir_ / "INDEX.txt").string() + ": write failed");
}

void FakenectDumpWriter::write(const Frame& frame) {
  if (frame.depth.type() != CV_16UC1 || frame.depth.cols != kFakenectWidth ||
      frame.depth.rows != kFakenectHeight) {
    throw std::invalid_argument("fakenect dumps hold 640x480 CV_16UC1 depth only");
  }
  if (!frame.rgb.empty() &&
      (frame.rgb.type() != CV_8UC3 || frame.rgb.size() != frame.depth.size())) {
    throw std::invalid_argument("fakenect dumps hold 640x480 CV_8UC3 colour only");
  }
  if (!first_ns_) first_ns_ = frame.timestamp_ns;
  const auto elapsed_ticks = static_cast<std::int64_t>(
      std::llround(static_cast<double>(frame.timestamp_ns - *first_ns_) * kDeviceTicksPerNs));
  const auto ticks = static_cast<std::uint32_t>(
      static_cast<std::uint64_t>(options_.first_device_ticks + elapsed_ticks) & 0xFFFFFFFFull);
  const std::string stem = formatNsAsSeconds(frame.timestamp_ns, 6) + "-" + std::to_string(ticks);

  const cv::Mat raw = kinectMmToRaw(frame.depth, options_.raw);
  std::string payload(kDepthBytes, '\0');
  for (int y = 0; y < raw.rows; ++y) {
    const auto* row = raw.ptr<std::uint16_t>(y);
    for (int x = 0; x < raw.cols; ++x) {
      const std::size_t i = 2 * (static_cast<std::size_t>(y) * kFakenectWidth + x);
      payload[i] = static_cast<char>(row[x] & 0xFF);
      payload[i + 1] = static_cast<char>(row[x] >> 8);
    }
  }
  const std::string depth_name = "d-" + stem + ".pgm";
  writeFileOrThrow(dir_ / depth_name, "P5 640 480 65535\n", payload);
  appendIndex(depth_name);

  if (!frame.rgb.empty()) {
    cv::Mat rgb;
    cv::cvtColor(frame.rgb, rgb, cv::COLOR_BGR2RGB);
    if (!rgb.isContinuous()) rgb = rgb.clone();
    const std::string rgb_name = "r-" + stem + ".ppm";
    writeFileOrThrow(dir_ / rgb_name, "P6 640 480 255\n",
                     std::string(reinterpret_cast<const char*>(rgb.data), kRgbBytes));
    appendIndex(rgb_name);
  }
}

void writeFakenectDump(const fs::path& dir, std::span<const Frame> frames,
                       const FakenectWriteOptions& options) {
  FakenectDumpWriter writer(dir, options);
  for (const Frame& frame : frames) writer.write(frame);
}

FakenectDumpSource::FakenectDumpSource(fs::path dir, FakenectDumpOptions options)
    : dir_(std::move(dir)), options_(std::move(options)), to_mm_(options_.raw) {
  FakenectIndex index = readFakenectIndex(dir_);
  problems_.assign(index.problems.begin(), index.problems.end());
  DeviceClock clock(options_.clock);
  for (const auto& entry : index.entries) {
    if (entry.type != 'd' && entry.type != 'r') continue;
    Stamped stamped{entry, clock.map(entry.device_ticks, entry.host_ns)};
    (entry.type == 'd' ? depth_ : rgb_).push_back(std::move(stamped));
  }
  if (depth_.empty()) {
    throw std::runtime_error((dir_ / "INDEX.txt").string() + ": lists no depth file");
  }
  std::sort(rgb_.begin(), rgb_.end(),
            [](const Stamped& a, const Stamped& b) { return a.capture_ns < b.capture_ns; });
}

std::string FakenectDumpSource::describe() const { return "fakenect:" + dir_.string(); }

const FakenectDumpSource::Stamped* FakenectDumpSource::nearestRgb(const Stamped& depth) const {
  const Stamped* best = nullptr;
  TimestampNs best_gap = std::chrono::nanoseconds(options_.max_rgb_offset).count();
  auto it = std::lower_bound(rgb_.begin(), rgb_.end(), depth.capture_ns,
                             [](const Stamped& s, TimestampNs t) { return s.capture_ns < t; });
  for (auto candidate : {it, it == rgb_.begin() ? rgb_.end() : std::prev(it)}) {
    if (candidate == rgb_.end()) continue;
    const TimestampNs gap = std::llabs(candidate->capture_ns - depth.capture_ns);
    if (gap <= best_gap) {
      best_gap = gap;
      best = &*candidate;
    }
  }
  return best;
}

bool FakenectDumpSource::waitUntil(TimestampNs host_ns, std::stop_token& stop) {
  if (options_.pacing != Pacing::kRecorded) return !stop.stop_requested();
  const auto now = std::chrono::steady_clock::now();
  if (!wall_start_) wall_start_ = now;
  const auto deadline =
      *wall_start_ + std::chrono::nanoseconds(host_ns - depth_.front().entry.host_ns);
  std::unique_lock lock(wait_mutex_);
  wait_cv_.wait_until(lock, stop, deadline, [] { return false; });
  return !stop.stop_requested();
}

SourceEvent FakenectDumpSource::next(std::stop_token stop) {
  if (!problems_.empty()) {
    SourceError error{problems_.front()};
    problems_.pop_front();
    return error;
  }
  if (stop.stop_requested() || position_ >= depth_.size()) return EndOfStream{};
  const Stamped& depth = depth_[position_++];
  if (!waitUntil(depth.entry.host_ns, stop)) return EndOfStream{};
  Frame frame;
  try {
    frame.depth = to_mm_.convert(readFakenectDepth(pathInside(dir_, depth.entry.file_name)));
  } catch (const std::exception& e) {
    return SourceError{e.what()};
  }
  if (const Stamped* rgb = nearestRgb(depth)) {
    try {
      frame.rgb = readFakenectRgb(pathInside(dir_, rgb->entry.file_name));
    } catch (const std::exception& e) {
      problems_.push_back(e.what());  // the depth frame still goes out, without colour
    }
  }
  frame.intrinsics = options_.intrinsics;
  frame.timestamp_ns = depth.capture_ns;
  frame.sequence = sequence_++;
  return frame;
}

}  // namespace shapesense
