#pragma once
// Noticing that a sensor was plugged in, so LiveSource reopens it at once instead of at its next
// poll. Arrivals come from libusb hotplug events where the platform has them (Linux with usbfs);
// where it does not (no LIBUSB_CAP_HAS_HOTPLUG, or a container without /dev/bus/usb) there are no
// events and LiveSource keeps polling at its reopen interval.
//
// The event source is an interface so tests can play arrivals without a device.

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <stop_token>
#include <string>
#include <vector>

namespace shapesense {

struct UsbId {
  std::uint16_t vendor = 0;
  std::uint16_t product = 0;
  friend bool operator==(const UsbId&, const UsbId&) = default;
};

/// "045e:02ae".
std::string toString(UsbId id);

/// Kinect v1, Xbox 360 model (camera, motor, audio) and Kinect for Windows (camera, audio,
/// motor), as libfreenect and Debian's OpenNI2 udev rules list them. Any of them arriving may
/// be the sensor coming back: the camera enumerates a moment after the motor.
inline constexpr std::array<UsbId, 6> kKinectUsbIds = {{{0x045e, 0x02ae},
                                                        {0x045e, 0x02b0},
                                                        {0x045e, 0x02ad},
                                                        {0x045e, 0x02bf},
                                                        {0x045e, 0x02be},
                                                        {0x045e, 0x02c2}}};

/// PrimeSense sensors and those built on them (PrimeSensor, ASUS Xtion / Xtion PRO LIVE,
/// Carmine 1.08 / 1.09), as Debian's OpenNI2 udev rules list them.
inline constexpr std::array<UsbId, 12> kPrimeSenseUsbIds = {{{0x1d27, 0x0200},
                                                             {0x1d27, 0x0300},
                                                             {0x1d27, 0x0400},
                                                             {0x1d27, 0x0401},
                                                             {0x1d27, 0x0500},
                                                             {0x1d27, 0x0600},
                                                             {0x1d27, 0x0601},
                                                             {0x1d27, 0x0609},
                                                             {0x1d27, 0x1280},
                                                             {0x1d27, 0x2100},
                                                             {0x1d27, 0x2200},
                                                             {0x1d27, 0xf9db}}};

/// Where USB arrivals come from: libusb hotplug in the daemon, a script in tests.
class UsbArrivalEvents {
 public:
  virtual ~UsbArrivalEvents() = default;
  /// Whether arrivals are reported at all; false: whoever waits for one must poll.
  virtual bool supported() const = 0;
  /// Why not supported (for the log), or what reports arrivals.
  virtual std::string describe() const = 0;
  /// Calls `on_arrival` (from any thread) for every device plugged in from now on, until this
  /// object is destroyed. Called at most once.
  virtual void start(std::function<void(UsbId)> on_arrival) = 0;
};

/// libusb hotplug on a private libusb context, with a thread of its own that handles its
/// events. Unsupported when libusb cannot be initialised (no USB) or has no hotplug capability.
std::unique_ptr<UsbArrivalEvents> makeLibusbArrivalEvents();

/// Waits for one of a set of devices to be plugged in.
class DeviceWatcher {
 public:
  /// Starts `events` (when supported) with this watcher's filter.
  DeviceWatcher(std::shared_ptr<UsbArrivalEvents> events, std::span<const UsbId> ids);
  ~DeviceWatcher();
  DeviceWatcher(const DeviceWatcher&) = delete;
  DeviceWatcher& operator=(const DeviceWatcher&) = delete;

  /// Whether arrivals are reported (otherwise waitForArrival only times out).
  bool hotplug() const { return hotplug_; }
  std::string describe() const { return description_; }
  /// Whether `id` is one of the watched devices.
  bool watches(UsbId id) const;

  /// Blocks until a watched device arrives (or has arrived since the last call or forget()),
  /// `timeout` passes or `stop` is requested. True when an arrival ended the wait.
  bool waitForArrival(std::chrono::milliseconds timeout, const std::stop_token& stop);
  /// Drops arrivals seen so far (the device was opened: they are accounted for).
  void forget();
  /// Watched devices that arrived since construction.
  std::uint64_t arrivals() const;

 private:
  void onArrival(UsbId id);

  std::shared_ptr<UsbArrivalEvents> events_;
  std::vector<UsbId> ids_;
  bool hotplug_ = false;
  std::string description_;

  mutable std::mutex mutex_;
  std::condition_variable_any arrived_;
  bool pending_ = false;
  std::uint64_t arrivals_ = 0;
};

}  // namespace shapesense
