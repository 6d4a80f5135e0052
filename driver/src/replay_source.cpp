#include "shapesense/driver/replay_source.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <variant>

#include <opencv2/imgcodecs.hpp>

#include "shapesense/driver/bounded_file.h"

namespace shapesense {
namespace {

// Sleeps until `deadline` or until stop is requested; returns false when stopped.
bool sleepUntil(std::chrono::steady_clock::time_point deadline, std::stop_token stop) {
  std::mutex mutex;
  std::condition_variable_any cv;
  std::unique_lock lock(mutex);
  return !cv.wait_until(lock, stop, deadline, [] { return false; }) && !stop.stop_requested();
}

// Median spacing of the depth stamps: the typical frame period of the recording.
TimestampNs typicalPeriod(const std::vector<TumIndexEntry>& depth) {
  if (depth.size() < 2) return 33'333'333;
  std::vector<TimestampNs> gaps;
  for (std::size_t i = 1; i < depth.size(); ++i) {
    gaps.push_back(depth[i].timestamp_ns - depth[i - 1].timestamp_ns);
  }
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return std::max<TimestampNs>(gaps[gaps.size() / 2], 1);
}

// 16-bit RGBA, the largest PNG pixel, plus room for ancillary chunks: a PNG of the camera's size
// cannot be larger, whatever it holds.
std::size_t imageFileLimit(const CameraIntrinsics& k) {
  constexpr std::size_t kMaxBytesPerPixel = 8;
  constexpr std::size_t kChunkSlack = 64 * 1024;
  return static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height) *
             kMaxBytesPerPixel +
         kChunkSlack;
}

struct PngSize {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
};

// Width and height from the IHDR chunk, which the PNG format puts first at a fixed offset:
// read before decoding, so a small file claiming a huge image is refused without allocating it.
std::optional<PngSize> pngSize(std::string_view bytes) {
  constexpr std::string_view kSignature("\x89PNG\r\n\x1a\n", 8);
  if (bytes.size() < 24 || bytes.substr(0, 8) != kSignature || bytes.substr(12, 4) != "IHDR") {
    return std::nullopt;
  }
  const auto big_endian = [&](std::size_t at) {
    std::uint32_t value = 0;
    for (std::size_t i = 0; i < 4; ++i)
      value = value << 8 | static_cast<unsigned char>(bytes[at + i]);
    return value;
  };
  return PngSize{big_endian(16), big_endian(20)};
}

// Reads and decodes a PNG of the recording's camera size, or says why it cannot.
// `what` ("depth image", "colour image") names it in the reason.
std::variant<cv::Mat, std::string> readCameraSizedPng(const std::filesystem::path& dir,
                                                      const std::filesystem::path& relative,
                                                      const CameraIntrinsics& k, int flags,
                                                      const std::string& what) {
  std::string bytes;
  std::filesystem::path path;
  try {
    path = pathInside(dir, relative);
    if (!std::filesystem::exists(path)) return path.string() + ": missing " + what;
    bytes = readRegularFile(path, imageFileLimit(k));
  } catch (const InputFileError& e) {
    return std::string(e.what());
  }
  const auto size = pngSize(bytes);
  if (!size) return path.string() + ": " + what + " is not a PNG (no PNG signature and header)";
  if (size->width != static_cast<std::uint32_t>(k.width) ||
      size->height != static_cast<std::uint32_t>(k.height)) {
    return path.string() + ": " + what + " is " + std::to_string(size->width) + "x" +
           std::to_string(size->height) + ", the recording's camera is " + std::to_string(k.width) +
           "x" + std::to_string(k.height);
  }
  cv::Mat image;
  try {
    image = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, bytes.data()), flags);
  } catch (const cv::Exception& e) {
    return path.string() + ": cannot decode " + what + " (" + quoteExcerpt(e.what(), 200) + ")";
  }
  if (image.empty()) return path.string() + ": cannot decode " + what + " (truncated or not a PNG)";
  return image;
}

}  // namespace

ReplaySource::ReplaySource(std::filesystem::path dir, ReplayOptions options)
    : dir_(std::move(dir)), options_(options), index_(readTumIndex(dir_)) {
  if (index_.depth.empty()) {
    throw std::runtime_error((dir_ / "depth.txt").string() + ": lists no depth image");
  }
  pending_problems_.assign(index_.problems.begin(), index_.problems.end());
  pass_length_ns_ = index_.depth.back().timestamp_ns - index_.depth.front().timestamp_ns +
                    typicalPeriod(index_.depth);
  recording_start_ns_ = index_.depth.front().timestamp_ns;
}

std::string ReplaySource::describe() const { return "tum:" + dir_.string(); }

const TumIndexEntry* ReplaySource::nearestRgb(TimestampNs t) const {
  const auto& rgb = index_.rgb;
  if (rgb.empty()) return nullptr;
  auto it = std::lower_bound(rgb.begin(), rgb.end(), t, [](const TumIndexEntry& e, TimestampNs v) {
    return e.timestamp_ns < v;
  });
  const TumIndexEntry* best = nullptr;
  TimestampNs best_gap = 0;
  for (auto candidate : {it, it == rgb.begin() ? it : std::prev(it)}) {
    if (candidate == rgb.end()) continue;
    const TimestampNs gap = std::abs(candidate->timestamp_ns - t);
    if (!best || gap < best_gap) {
      best = &*candidate;
      best_gap = gap;
    }
  }
  const TimestampNs max_gap =
      std::chrono::duration_cast<std::chrono::nanoseconds>(options_.max_rgb_offset).count();
  return best_gap <= max_gap ? best : nullptr;
}

SourceEvent ReplaySource::loadFrame(const TumIndexEntry& entry, TimestampNs timestamp_ns) {
  const auto& k = index_.camera.intrinsics;
  auto depth =
      readCameraSizedPng(dir_, entry.relative_path, k, cv::IMREAD_UNCHANGED, "depth image");
  if (auto* reason = std::get_if<std::string>(&depth)) return SourceError{*reason};
  const cv::Mat& raw = std::get<cv::Mat>(depth);
  if (raw.type() != CV_16UC1) {
    return SourceError{(dir_ / entry.relative_path).string() +
                       ": depth must be a 16-bit single-channel PNG"};
  }
  Frame frame;
  raw.convertTo(frame.depth, CV_16UC1, 1000.0 / index_.camera.depth_scale);
  frame.intrinsics = k;
  frame.timestamp_ns = timestamp_ns;
  frame.sequence = sequence_++;
  if (const TumIndexEntry* rgb = nearestRgb(entry.timestamp_ns)) {
    // A bad colour image costs the frame its colour, not the frame.
    auto colour = readCameraSizedPng(dir_, rgb->relative_path, k, cv::IMREAD_COLOR, "colour image");
    if (auto* image = std::get_if<cv::Mat>(&colour)) frame.rgb = std::move(*image);
  }
  return frame;
}

SourceEvent ReplaySource::next(std::stop_token stop) {
  if (!pending_problems_.empty()) {
    SourceError error{pending_problems_.front()};
    pending_problems_.pop_front();
    return error;
  }
  if (position_ == index_.depth.size()) {
    if (!options_.loop) return EndOfStream{};
    position_ = 0;
    ++pass_;
  }
  if (stop.stop_requested()) return EndOfStream{};
  const TumIndexEntry& entry = index_.depth[position_++];
  TimestampNs shift = 0;
  TimestampNs stamp = 0;
  if (__builtin_mul_overflow(static_cast<TimestampNs>(pass_), pass_length_ns_, &shift) ||
      __builtin_add_overflow(entry.timestamp_ns, shift, &stamp)) {
    // Past 2262 stamps would wrap to the past and every frame would be refused: stop, once.
    position_ = index_.depth.size();
    options_.loop = false;
    return SourceError{describe() + ": looped " + std::to_string(pass_) +
                       " times, to the end of the 64-bit nanosecond clock; the replay ends"};
  }
  if (options_.pacing == Pacing::kRecorded) {
    if (!started_) {
      started_ = true;
      wall_start_ = std::chrono::steady_clock::now();
    }
    const auto due = wall_start_ + std::chrono::nanoseconds(stamp - recording_start_ns_);
    if (!sleepUntil(due, stop)) return EndOfStream{};
  }
  return loadFrame(entry, stamp);
}

}  // namespace shapesense
