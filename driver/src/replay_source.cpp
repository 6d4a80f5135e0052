#include "shapesense/driver/replay_source.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

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
  const auto path = dir_ / entry.relative_path;
  const auto& k = index_.camera.intrinsics;
  if (!std::filesystem::exists(path)) return SourceError{path.string() + ": missing depth image"};
  cv::Mat raw;
  try {
    raw = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return SourceError{path.string() + ": cannot decode depth image (" + e.what() + ")"};
  }
  if (raw.empty())
    return SourceError{path.string() + ": cannot decode depth image (truncated or not a PNG)"};
  if (raw.type() != CV_16UC1) {
    return SourceError{path.string() + ": depth must be a 16-bit single-channel PNG"};
  }
  if (raw.cols != k.width || raw.rows != k.height) {
    return SourceError{path.string() + ": depth image is " + std::to_string(raw.cols) + "x" +
                       std::to_string(raw.rows) + ", the recording's camera is " +
                       std::to_string(k.width) + "x" + std::to_string(k.height)};
  }
  Frame frame;
  raw.convertTo(frame.depth, CV_16UC1, 1000.0 / index_.camera.depth_scale);
  frame.intrinsics = k;
  frame.timestamp_ns = timestamp_ns;
  frame.sequence = sequence_++;
  if (const TumIndexEntry* rgb = nearestRgb(entry.timestamp_ns)) {
    // A bad colour image costs the frame its colour, not the frame.
    cv::Mat colour = cv::imread((dir_ / rgb->relative_path).string(), cv::IMREAD_COLOR);
    if (!colour.empty() && colour.size() == frame.depth.size()) frame.rgb = colour;
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
  const TimestampNs stamp = entry.timestamp_ns + static_cast<TimestampNs>(pass_) * pass_length_ns_;
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
