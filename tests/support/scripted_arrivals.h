#pragma once
// USB arrivals fired by a test, for DeviceWatcher and LiveSource without a device.

#include <functional>
#include <mutex>
#include <string>

#include "shapesense/driver/usb_hotplug.h"

namespace shapesense::testing {

class ScriptedArrivals final : public UsbArrivalEvents {
 public:
  /// `supported` false: like a container without USB, nothing is ever delivered.
  explicit ScriptedArrivals(bool supported) : supported_(supported) {}
  bool supported() const override { return supported_; }
  std::string describe() const override {
    return supported_ ? "scripted arrivals" : "no USB hotplug: scripted";
  }
  void start(std::function<void(UsbId)> on_arrival) override {
    std::lock_guard lock(mutex_);
    on_arrival_ = std::move(on_arrival);
  }
  /// Delivers an arrival of `id` as libusb's event thread would, if started.
  void plugIn(UsbId id) {
    std::lock_guard lock(mutex_);
    if (on_arrival_) on_arrival_(id);
  }

 private:
  bool supported_;
  std::mutex mutex_;
  std::function<void(UsbId)> on_arrival_;
};

}  // namespace shapesense::testing
