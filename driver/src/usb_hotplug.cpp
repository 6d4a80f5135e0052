#include "shapesense/driver/usb_hotplug.h"

#include <libusb.h>

#include <algorithm>
#include <cstdio>
#include <thread>

namespace shapesense {
namespace {

class LibusbArrivalEvents final : public UsbArrivalEvents {
 public:
  LibusbArrivalEvents() {
    if (const int error = libusb_init(&context_); error != 0) {
      context_ = nullptr;
      description_ =
          std::string("no USB hotplug: libusb cannot start (") + libusb_error_name(error) + ")";
      return;
    }
    if (!libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
      description_ = "no USB hotplug: libusb has no hotplug support on this platform";
      return;
    }
    // In a container without /dev/bus/usb libusb still starts and claims hotplug, but no event
    // ever comes: a machine with USB has at least its root hubs, so no device means no USB.
    libusb_device** devices = nullptr;
    const ssize_t count = libusb_get_device_list(context_, &devices);
    if (devices) libusb_free_device_list(devices, 1);
    if (count <= 0) {
      description_ = "no USB hotplug: libusb sees no USB device (no /dev/bus/usb here?)";
      return;
    }
    description_ = "libusb hotplug";
    supported_ = true;
  }

  ~LibusbArrivalEvents() override {
    if (thread_.joinable()) {
      thread_.request_stop();
      libusb_interrupt_event_handler(context_);
      thread_.join();
    }
    if (context_) {
      if (registered_) libusb_hotplug_deregister_callback(context_, handle_);
      libusb_exit(context_);
    }
  }

  bool supported() const override { return supported_; }
  std::string describe() const override { return description_; }

  void start(std::function<void(UsbId)> on_arrival) override {
    if (!supported_ || registered_) return;
    on_arrival_ = std::move(on_arrival);
    // Any vendor: the watcher filters. A callback per vendor would need one handle each.
    const int error = libusb_hotplug_register_callback(
        context_, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED, LIBUSB_HOTPLUG_NO_FLAGS,
        LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, &onEvent,
        this, &handle_);
    if (error != LIBUSB_SUCCESS) {
      supported_ = false;
      description_ = std::string("no USB hotplug: libusb refused the callback (") +
                     libusb_error_name(error) + ")";
      return;
    }
    registered_ = true;
    thread_ = std::jthread([this](std::stop_token stop) {
      while (!stop.stop_requested()) {
        // The destructor interrupts this wait; the timeout only bounds a missed interrupt.
        timeval timeout{1, 0};
        libusb_handle_events_timeout_completed(context_, &timeout, nullptr);
      }
    });
  }

 private:
  static int LIBUSB_CALL onEvent(libusb_context*, libusb_device* device, libusb_hotplug_event,
                                 void* self) {
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(device, &descriptor) == LIBUSB_SUCCESS) {
      static_cast<LibusbArrivalEvents*>(self)->on_arrival_(
          UsbId{descriptor.idVendor, descriptor.idProduct});
    }
    return 0;  // stay registered
  }

  libusb_context* context_ = nullptr;
  bool supported_ = false;
  bool registered_ = false;
  std::string description_;
  libusb_hotplug_callback_handle handle_{};
  std::function<void(UsbId)> on_arrival_;
  std::jthread thread_;
};

}  // namespace

std::string toString(UsbId id) {
  char text[16];
  std::snprintf(text, sizeof text, "%04x:%04x", id.vendor, id.product);
  return text;
}

std::unique_ptr<UsbArrivalEvents> makeLibusbArrivalEvents() {
  return std::make_unique<LibusbArrivalEvents>();
}

DeviceWatcher::DeviceWatcher(std::shared_ptr<UsbArrivalEvents> events, std::span<const UsbId> ids)
    : events_(std::move(events)), ids_(ids.begin(), ids.end()) {
  if (events_ && events_->supported()) events_->start([this](UsbId id) { onArrival(id); });
  // start() may find out it cannot deliver after all.
  hotplug_ = events_ && events_->supported();
  description_ = events_ ? events_->describe() : "no USB hotplug";
}

DeviceWatcher::~DeviceWatcher() {
  // The events stop calling onArrival when destroyed; another owner may keep them alive.
  events_.reset();
}

bool DeviceWatcher::watches(UsbId id) const {
  return std::find(ids_.begin(), ids_.end(), id) != ids_.end();
}

void DeviceWatcher::onArrival(UsbId id) {
  if (!watches(id)) return;
  {
    std::lock_guard lock(mutex_);
    pending_ = true;
    ++arrivals_;
  }
  arrived_.notify_all();
}

bool DeviceWatcher::waitForArrival(std::chrono::milliseconds timeout, const std::stop_token& stop) {
  std::unique_lock lock(mutex_);
  arrived_.wait_for(lock, stop, timeout, [this] { return pending_; });
  const bool arrived = pending_;
  pending_ = false;
  return arrived;
}

void DeviceWatcher::forget() {
  std::lock_guard lock(mutex_);
  pending_ = false;
}

std::uint64_t DeviceWatcher::arrivals() const {
  std::lock_guard lock(mutex_);
  return arrivals_;
}

}  // namespace shapesense
