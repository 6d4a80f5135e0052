#pragma once
// The machinery shared by live sensor sources (libfreenect, OpenNI2): a device thread that opens
// the sensor, pumps its events, notices loss (error return, no frame within a timeout) and
// reopens it, stamps images through DeviceClock, pairs depth with colour, and queues frames and
// errors for FrameSource::next().
//
// Each stream has its own DeviceClock: pairing then does not depend on the streams sharing one
// counter (OpenNI2's DummyDevice counts each stream from its own start), at the price of the
// difference between the streams' median transport latencies (a few ms, well inside the 20 ms
// pairing tolerance).
//
// Device specifics sit behind two small interfaces: a DeviceConnector opens the sensor and
// returns a DeviceSession, which delivers images while it is alive and is destroyed (closing
// the device) when the sensor is lost or the source stops. Both are used only on the device
// thread.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>
#include <thread>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/driver/device_clock.h"
#include "shapesense/driver/frame_source.h"
#include "shapesense/driver/live_sources_pairing.h"
#include "shapesense/driver/usb_hotplug.h"

namespace shapesense {

/// One image as a device delivered it.
struct DeviceImage {
  enum class Kind { kDepth, kColour };
  Kind kind = Kind::kDepth;
  cv::Mat image;                    ///< depth: CV_16UC1 mm; colour: CV_8UC3 BGR
  std::uint64_t device_ticks = 0;   ///< the device's own counter (see DeviceClockParams)
  TimestampNs host_arrival_ns = 0;  ///< host CLOCK_REALTIME when the image was received
};

using DeviceImageSink = std::function<void(DeviceImage)>;

/// An open sensor. Destroying it stops the streams and closes the device.
class DeviceSession {
 public:
  virtual ~DeviceSession() = default;
  /// Waits up to `budget` for data and hands each received image to `sink`. Returns an error
  /// message when the device failed (the session is then destroyed and the device reopened).
  virtual std::optional<std::string> pump(std::chrono::milliseconds budget,
                                          const DeviceImageSink& sink) = 0;
  /// Intrinsics of the depth images this session delivers.
  virtual CameraIntrinsics intrinsics() const = 0;
  /// Whether a colour stream runs (otherwise depth frames are released without waiting).
  virtual bool hasColour() const = 0;
  /// E.g. "Kinect serial A00364A11700045A"; shown in logs when the device (re)connects.
  virtual std::string name() const = 0;
};

/// Opens sessions on one configured device.
class DeviceConnector {
 public:
  virtual ~DeviceConnector() = default;
  /// For FrameSource::describe(), e.g. "freenect:0".
  virtual std::string describe() const = 0;
  /// Opens the device; nullptr with `why_not` set when it is not there (yet) or fails to start.
  virtual std::unique_ptr<DeviceSession> open(std::string& why_not) = 0;
  /// The device counter of DeviceImage::device_ticks.
  virtual DeviceClockParams clockParams() const = 0;
  /// USB ids whose arrival may be this device coming back; empty: not a USB device (a file,
  /// OpenNI2's Dummy), reopened by polling only.
  virtual std::span<const UsbId> usbIds() const { return {}; }
};

struct LiveSourceOptions {
  /// No frame for this long from an open device counts as loss. Default 3 s.
  std::chrono::milliseconds frame_timeout{3000};
  /// Pause between attempts to (re)open the device, and the first pause after a loss. Default 1 s.
  std::chrono::milliseconds reopen_interval{1000};
  /// Reopen an absent device when one of the connector's usbIds() is plugged in, at once. While
  /// arrivals are reported, an absent device is also polled every hotplug_poll_interval (a
  /// device the ids do not name); without them (see usb_hotplug.h) every reopen_interval.
  /// Default on.
  bool usb_hotplug = true;
  /// Where arrivals come from (tests); null: libusb hotplug. Give each source its own.
  std::shared_ptr<UsbArrivalEvents> usb_arrivals;
  /// Default 10 s.
  std::chrono::milliseconds hotplug_poll_interval{10000};
  /// Longest single wait inside DeviceSession::pump (bounds stop latency). Default 100 ms.
  std::chrono::milliseconds pump_budget{100};
  /// Frames queued for next(); when full the oldest is dropped (and counted). Default 4.
  std::size_t max_queued_frames = 4;
  PairingParams pairing{};  ///< depth/colour pairing. Defaults: see PairingParams.
};

/// A FrameSource driven by a device thread, see the top of this file. Frames carry host-clock
/// capture times (device counters mapped by DeviceClock, strictly increasing across reconnects)
/// and sequence numbers that continue across reconnects. next() returns SourceError when the
/// device is lost ("... lost: <reason>; reopening every 1 s") and once when it is not found
/// ("... not available: <reason>; waiting for it"), then blocks until frames come again.
class LiveSource : public FrameSource {
 public:
  /// Starts the device thread at once; the device need not be present.
  LiveSource(std::unique_ptr<DeviceConnector> connector, LiveSourceOptions options = {});
  /// Stops the device thread and closes the device.
  ~LiveSource() override;
  LiveSource(const LiveSource&) = delete;
  LiveSource& operator=(const LiveSource&) = delete;

  std::string describe() const override;
  /// The next frame or error; EndOfStream once `stop` is requested.
  SourceEvent next(std::stop_token stop) override;

  /// Whether the device is open and delivering (false while waiting for or reopening it).
  bool connected() const { return connected_.load(); }
  /// Times the device was opened (1 after the first connection, +1 per reconnection).
  std::uint64_t connections() const { return connections_.load(); }
  /// Frames dropped because next() was not called fast enough.
  std::uint64_t droppedFrames() const { return dropped_.load(); }
  /// Whether USB arrivals reopen the device (false: it is polled).
  bool hotplug() const { return watcher_ && watcher_->hotplug(); }
  /// Last error reported (empty if none), for status displays.
  std::string lastError() const;
  /// live, connected(), connections() - 1 (reopenings), losses, droppedFrames().
  SourceHealth health() const override;

 private:
  void run(std::stop_token stop);
  void runSession(DeviceSession& session, std::stop_token stop, std::string& failure);
  void onImage(DeviceImage image, DeviceSession& session, bool& delivered);
  void emitFrames(std::vector<PairedImages> pairs, const CameraIntrinsics& intrinsics);
  void postError(std::string message);
  void sleepFor(std::chrono::milliseconds duration, const std::stop_token& stop);
  /// Pauses before the next open attempt: `interval`, cut short by a watched USB arrival.
  void waitToReopen(std::chrono::milliseconds interval, const std::stop_token& stop);
  std::string reopenPolicy() const;

  std::unique_ptr<DeviceConnector> connector_;
  LiveSourceOptions options_;
  std::string description_;

  // Device thread only.
  DeviceClock clock_;         // depth stream
  DeviceClock colour_clock_;  // colour stream
  DepthColourPairer pairer_;
  TimestampNs last_stamp_ = 0;

  mutable std::mutex mutex_;
  std::condition_variable_any ready_;
  std::deque<SourceEvent> queue_;
  std::size_t queued_frames_ = 0;
  std::string last_error_;
  std::uint64_t next_sequence_ = 0;  // assigned in next()
  std::atomic<bool> connected_{false};
  std::atomic<std::uint64_t> connections_{0};
  std::atomic<std::uint64_t> disconnects_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::mutex sleep_mutex_;  // only for the device thread's stop-aware pauses
  std::condition_variable_any sleep_cv_;
  std::unique_ptr<DeviceWatcher> watcher_;  // null: no USB ids, or hotplug off

  std::jthread thread_;  // last: stopped and joined first on destruction
};

/// Host CLOCK_REALTIME in ns since the epoch.
TimestampNs hostNowNs();

}  // namespace shapesense
