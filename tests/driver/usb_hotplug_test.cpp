// DeviceWatcher without a device: the id filter, arrivals consumed once, no events (polling),
// and libusb's own event source starting and stopping wherever the tests run.

#include "shapesense/driver/usb_hotplug.h"
#include "scripted_arrivals.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

namespace shapesense {
namespace {

using namespace std::chrono_literals;

using testing::ScriptedArrivals;

bool lists(std::span<const UsbId> ids, UsbId id) {
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}

TEST(UsbIds, NameTheKinectAndPrimeSenseDevices) {
  EXPECT_TRUE(lists(kKinectUsbIds, {0x045e, 0x02ae}));   // camera
  EXPECT_TRUE(lists(kKinectUsbIds, {0x045e, 0x02b0}));   // motor
  EXPECT_TRUE(lists(kKinectUsbIds, {0x045e, 0x02bf}));   // Kinect for Windows camera
  EXPECT_FALSE(lists(kKinectUsbIds, {0x045e, 0x0040}));  // a Microsoft mouse
  EXPECT_TRUE(lists(kPrimeSenseUsbIds, {0x1d27, 0x0600}));
  EXPECT_TRUE(lists(kPrimeSenseUsbIds, {0x1d27, 0x0601}));  // Xtion PRO LIVE
  EXPECT_EQ(toString({0x045e, 0x02ae}), "045e:02ae");
}

TEST(DeviceWatcher, WakesOnlyForWatchedDevicesAndOncePerArrival) {
  auto events = std::make_shared<ScriptedArrivals>(true);
  DeviceWatcher watcher(events, kKinectUsbIds);
  EXPECT_TRUE(watcher.hotplug());
  std::stop_source stop;
  events->plugIn({0x046d, 0xc52b});  // a Logitech receiver
  events->plugIn({0x1d27, 0x0600});  // a PrimeSense sensor, not what this watcher waits for
  EXPECT_FALSE(watcher.waitForArrival(0ms, stop.get_token()));
  EXPECT_EQ(watcher.arrivals(), 0u);
  events->plugIn({0x045e, 0x02ae});
  EXPECT_EQ(watcher.arrivals(), 1u);
  EXPECT_TRUE(watcher.waitForArrival(0ms, stop.get_token()));
  EXPECT_FALSE(watcher.waitForArrival(0ms, stop.get_token()));  // consumed
  events->plugIn({0x045e, 0x02b0});
  watcher.forget();
  EXPECT_FALSE(watcher.waitForArrival(0ms, stop.get_token()));
}

TEST(DeviceWatcher, WithoutHotplugOnlyTimesOut) {
  auto events = std::make_shared<ScriptedArrivals>(false);
  DeviceWatcher watcher(events, kKinectUsbIds);
  EXPECT_FALSE(watcher.hotplug());
  events->plugIn({0x045e, 0x02ae});  // never started: nothing is delivered
  std::stop_source stop;
  EXPECT_FALSE(watcher.waitForArrival(10ms, stop.get_token()));
  DeviceWatcher no_events(nullptr, kKinectUsbIds);
  EXPECT_FALSE(no_events.hotplug());
}

TEST(DeviceWatcher, StopEndsTheWait) {
  DeviceWatcher watcher(std::make_shared<ScriptedArrivals>(true), kKinectUsbIds);
  std::stop_source stop;
  stop.request_stop();
  EXPECT_FALSE(watcher.waitForArrival(std::chrono::hours(1), stop.get_token()));
}

TEST(LibusbArrivalEvents, StartsAndStopsOrSaysWhyNot) {
  // With USB (a workstation) it reports arrivals; in a container without /dev/bus/usb it says
  // why not. Either way a watcher over it starts and is destroyed without hanging.
  std::shared_ptr<UsbArrivalEvents> events = makeLibusbArrivalEvents();
  const std::string description = events->describe();
  if (events->supported()) {
    EXPECT_EQ(description, "libusb hotplug");
  } else {
    EXPECT_THAT(description, ::testing::StartsWith("no USB hotplug: "));
  }
  std::cout << "libusb: " << description << "\n";
  DeviceWatcher watcher(std::move(events), kKinectUsbIds);
  std::stop_source stop;
  EXPECT_FALSE(watcher.waitForArrival(0ms, stop.get_token()));
}

}  // namespace
}  // namespace shapesense
