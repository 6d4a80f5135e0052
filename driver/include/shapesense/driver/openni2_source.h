#pragma once
// PrimeSense / Asus Xtion (and any other OpenNI2 device) through OpenNI2: a depth stream in
// millimetres and a colour stream, read by one device thread with OpenNI::waitForAnyStream.
// Device timestamps (64-bit microseconds) are mapped to host time with DeviceClock, colour is
// paired with depth by time, and the depth-to-colour registration mode is switched on when the
// device supports it. Loss (error returns, a disconnect event, or silence) and return of the
// device are handled by LiveSource (see live_sources_device.h).
//
// Debian's OpenNI2 has no Kinect v1 driver (use FreenectSource for those). Its DummyDevice
// driver (URI "Dummy": 320x240 depth and RGB at 30 fps) is a test device.
//
// OpenNI::initialize() is called once per process and OpenNI is never shut down (drivers'
// threads may still run at exit).

#include <memory>
#include <optional>
#include <string>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/driver/device_clock.h"
#include "shapesense/driver/live_sources_device.h"

namespace shapesense {

struct OpenNI2Options {
  std::string uri;     ///< device URI; empty = the first device OpenNI2 lists. Default empty.
  bool colour = true;  ///< also stream colour when the device has it. Default true.
  /// Ask for depth registered to colour when supported (then intrinsics are the colour
  /// camera's). Default true.
  bool registration = true;
  int width = 640;   ///< preferred resolution; the closest supported mode is used. Default 640.
  int height = 480;  ///< Default 480.
  int fps = 30;      ///< preferred frame rate. Default 30.
  /// Intrinsics of the delivered depth; nullopt = from the stream's field of view, or the
  /// Kinect-class default (525 px at 640 wide, scaled) when the device does not report it.
  std::optional<CameraIntrinsics> intrinsics;
  /// OpenNI2 frame stamps are 64-bit microseconds.
  DeviceClockParams clock{1e6, 64};
  LiveSourceOptions live{};  ///< timeouts, reopening, queue. Defaults: see LiveSourceOptions.
};

/// "openni2[:URI]" source. Never fails for a missing device: it waits for one.
class OpenNI2Source final : public LiveSource {
 public:
  explicit OpenNI2Source(OpenNI2Options options = {});
};

/// The connector behind OpenNI2Source (exposed for tests).
std::unique_ptr<DeviceConnector> makeOpenNI2Connector(OpenNI2Options options);

}  // namespace shapesense
