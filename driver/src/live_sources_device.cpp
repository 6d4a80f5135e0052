#include "shapesense/driver/live_sources_device.h"

#include <spdlog/spdlog.h>

#include <cstdio>

namespace shapesense {
namespace {

constexpr std::size_t kMaxQueuedErrors = 16;

/// "250 ms" below a second, "1.5 s" above.
std::string seconds(std::chrono::milliseconds duration) {
  if (duration < std::chrono::seconds(1)) return std::to_string(duration.count()) + " ms";
  char text[32];
  std::snprintf(text, sizeof text, "%.1f s", duration.count() / 1000.0);
  return text;
}

}  // namespace

TimestampNs hostNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

LiveSource::LiveSource(std::unique_ptr<DeviceConnector> connector, LiveSourceOptions options)
    : connector_(std::move(connector)),
      options_(options),
      description_(connector_->describe()),
      clock_(connector_->clockParams()),
      colour_clock_(connector_->clockParams()),
      pairer_(options_.pairing) {
  if (options_.usb_hotplug && !connector_->usbIds().empty()) {
    auto events = options_.usb_arrivals ? options_.usb_arrivals : makeLibusbArrivalEvents();
    watcher_ = std::make_unique<DeviceWatcher>(std::move(events), connector_->usbIds());
    spdlog::info("{}: {}", description_,
                 watcher_->hotplug() ? "reopens when the sensor is plugged in (USB hotplug)"
                                     : watcher_->describe() + "; polling");
  }
  thread_ = std::jthread([this](std::stop_token stop) { run(stop); });
}

LiveSource::~LiveSource() {
  thread_.request_stop();
  if (thread_.joinable()) thread_.join();
}

std::string LiveSource::describe() const { return description_; }

SourceHealth LiveSource::health() const {
  const std::uint64_t connections = connections_.load();
  return SourceHealth{.live = true,
                      .connected = connected_.load(),
                      .reconnects = connections > 0 ? connections - 1 : 0,
                      .disconnects = disconnects_.load(),
                      .dropped_frames = dropped_.load()};
}

std::string LiveSource::lastError() const {
  std::lock_guard lock(mutex_);
  return last_error_;
}

SourceEvent LiveSource::next(std::stop_token stop) {
  std::unique_lock lock(mutex_);
  if (!ready_.wait(lock, stop, [this] { return !queue_.empty(); })) return EndOfStream{};
  SourceEvent event = std::move(queue_.front());
  queue_.pop_front();
  if (auto* frame = std::get_if<Frame>(&event)) {
    --queued_frames_;
    frame->sequence = next_sequence_++;  // in delivery order: drops leave no gaps
  }
  return event;
}

void LiveSource::postError(std::string message) {
  spdlog::warn("{}", message);
  {
    std::lock_guard lock(mutex_);
    last_error_ = message;
    std::size_t errors = queue_.size() - queued_frames_;
    if (errors >= kMaxQueuedErrors) {
      // Nobody is reading: drop the oldest error, keep frames.
      for (auto it = queue_.begin(); it != queue_.end(); ++it) {
        if (std::holds_alternative<SourceError>(*it)) {
          queue_.erase(it);
          break;
        }
      }
    }
    queue_.push_back(SourceError{std::move(message)});
  }
  ready_.notify_all();
}

void LiveSource::sleepFor(std::chrono::milliseconds duration, const std::stop_token& stop) {
  std::unique_lock lock(sleep_mutex_);
  sleep_cv_.wait_for(lock, stop, duration, [] { return false; });
}

void LiveSource::waitToReopen(std::chrono::milliseconds interval, const std::stop_token& stop) {
  if (watcher_) {
    watcher_->waitForArrival(interval, stop);
  } else {
    sleepFor(interval, stop);
  }
}

std::string LiveSource::reopenPolicy() const {
  if (hotplug()) {
    return "reopening when it is plugged in (USB hotplug), else every " +
           seconds(options_.hotplug_poll_interval);
  }
  return "retrying every " + seconds(options_.reopen_interval);
}

void LiveSource::run(std::stop_token stop) {
  bool reported_absent = false;
  while (!stop.stop_requested()) {
    std::string why_not;
    std::unique_ptr<DeviceSession> session = connector_->open(why_not);
    if (!session) {
      if (!reported_absent) {
        postError(description_ + ": sensor not available: " + why_not + "; waiting for it (" +
                  reopenPolicy() + ")");
        reported_absent = true;
      }
      waitToReopen(hotplug() ? options_.hotplug_poll_interval : options_.reopen_interval, stop);
      continue;
    }
    reported_absent = false;
    // Arrivals so far (the motor before the camera) led here; only later ones mean a return.
    if (watcher_) watcher_->forget();
    clock_.reset();
    colour_clock_.reset();
    pairer_.reset();
    ++connections_;
    connected_ = true;
    spdlog::info("{}: connected to {}", description_, session->name());

    std::string failure;
    runSession(*session, stop, failure);
    connected_ = false;
    session.reset();  // stops the streams and closes the device
    if (stop.stop_requested()) break;
    ++disconnects_;
    postError(description_ + ": sensor lost: " + failure + "; reopening every " +
              seconds(options_.reopen_interval));
    // A sensor that went silent may still be plugged in and send no arrival: try again soon.
    waitToReopen(options_.reopen_interval, stop);
  }
}

void LiveSource::runSession(DeviceSession& session, std::stop_token stop, std::string& failure) {
  auto last_frame = std::chrono::steady_clock::now();
  const CameraIntrinsics intrinsics = session.intrinsics();
  const DeviceImageSink sink = [&](DeviceImage image) {
    bool delivered = false;
    onImage(std::move(image), session, delivered);
    if (delivered) last_frame = std::chrono::steady_clock::now();
  };
  while (!stop.stop_requested()) {
    if (auto error = session.pump(options_.pump_budget, sink)) {
      failure = *error;
      emitFrames(pairer_.flush(), intrinsics);
      return;
    }
    const auto silent = std::chrono::steady_clock::now() - last_frame;
    if (silent > options_.frame_timeout) {
      failure = "no depth frame for " +
                seconds(std::chrono::duration_cast<std::chrono::milliseconds>(silent));
      emitFrames(pairer_.flush(), intrinsics);
      return;
    }
  }
}

void LiveSource::onImage(DeviceImage image, DeviceSession& session, bool& delivered) {
  if (image.kind == DeviceImage::Kind::kDepth) {
    const TimestampNs t = clock_.map(image.device_ticks, image.host_arrival_ns);
    auto pairs = pairer_.addDepth({std::move(image.image), t});
    if (!session.hasColour()) {
      auto rest = pairer_.flush();
      pairs.insert(pairs.end(), std::make_move_iterator(rest.begin()),
                   std::make_move_iterator(rest.end()));
    }
    emitFrames(std::move(pairs), session.intrinsics());
    delivered = true;
    return;
  }
  // Colour has its own clock filter: some devices (OpenNI2's DummyDevice) count each stream
  // from its own start, and per-stream filters only differ by the streams' latency difference.
  const TimestampNs t = colour_clock_.map(image.device_ticks, image.host_arrival_ns);
  emitFrames(pairer_.addColour({std::move(image.image), t}), session.intrinsics());
}

void LiveSource::emitFrames(std::vector<PairedImages> pairs, const CameraIntrinsics& intrinsics) {
  if (pairs.empty()) return;
  {
    std::lock_guard lock(mutex_);
    for (auto& pair : pairs) {
      Frame frame;
      frame.depth = std::move(pair.depth.image);
      frame.rgb = std::move(pair.colour);
      frame.intrinsics = intrinsics;
      // Strictly increasing across reconnects and filter corrections.
      frame.timestamp_ns = std::max(pair.depth.capture_ns, last_stamp_ + 1);
      last_stamp_ = frame.timestamp_ns;
      if (queued_frames_ >= options_.max_queued_frames) {
        for (auto it = queue_.begin(); it != queue_.end(); ++it) {
          if (std::holds_alternative<Frame>(*it)) {
            queue_.erase(it);
            --queued_frames_;
            ++dropped_;
            break;
          }
        }
      }
      queue_.push_back(std::move(frame));
      ++queued_frames_;
    }
  }
  ready_.notify_all();
}

}  // namespace shapesense
