#include "shapesense/driver/synthetic_source.h"

#include <cmath>
#include <ctime>
#include <stdexcept>
#include <utility>

namespace shapesense::synthetic {

namespace {

SceneParams withFrameRate(SceneParams scene, double fps) {
  if (!(fps > 0.0)) throw std::invalid_argument("SyntheticSourceOptions: fps must be positive");
  scene.frame_rate_hz = fps;
  return scene;
}

TimestampNs realtimeNow() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<TimestampNs>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

SyntheticSource::SyntheticSource(SyntheticSourceOptions options)
    : options_(std::move(options)),
      scene_(withFrameRate(options_.scene, options_.fps)),
      start_ns_(options_.start_ns != 0 ? options_.start_ns : realtimeNow()) {}

std::string SyntheticSource::describe() const {
  return "synthetic(seed=" + std::to_string(options_.scene.seed) + ")";
}

TimestampNs SyntheticSource::stampOf(std::uint64_t index) const {
  return start_ns_ + std::llround(static_cast<double>(index) * 1e9 / options_.fps);
}

SourceEvent SyntheticSource::next(std::stop_token stop) {
  if (stop.stop_requested()) return EndOfStream{};
  if (options_.max_frames != 0 && next_index_ >= options_.max_frames) return EndOfStream{};
  const auto now = std::chrono::steady_clock::now();
  if (!first_call_) first_call_ = now;
  if (options_.pacing == Pacing::kRecorded) {
    const auto due =
        *first_call_ +
        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::chrono::duration<double>(static_cast<double>(next_index_) / options_.fps));
    std::unique_lock lock(wait_mutex_);
    // Nothing ever notifies: the wait ends at the deadline or on the stop request.
    wait_cv_.wait_until(lock, stop, due, [] { return false; });
    if (stop.stop_requested()) return EndOfStream{};
  }
  const std::uint64_t index = next_index_++;
  RenderedFrame rendered = scene_.render(index, stampOf(index));
  last_truth_ = std::move(rendered.truth);
  return std::move(rendered.frame);
}

}  // namespace shapesense::synthetic
