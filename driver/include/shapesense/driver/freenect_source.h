#pragma once
// Kinect v1 through libfreenect: 640x480 11-bit raw depth (converted to millimetres with
// kinect_raw.h) and 640x480 RGB, both at 30 Hz, on one device thread that runs
// freenect_process_events. Frames are stamped by mapping the 32-bit 60 MHz device counter to
// host time (DeviceClock, one per stream) and colour is paired with depth by time. Loss and return
// of the sensor are handled by LiveSource (see live_sources_device.h).
//
// The colour image comes from the RGB camera, ~2.5 cm beside the IR camera, and is NOT
// registered to the depth image (registration needs freenect_copy_registration, which the
// fakenect test library lacks); treat the pairing as approximate near depth edges.
//
// Runs unchanged under Debian's fakenect library (LD_LIBRARY_PATH=<multiarch>/fakenect,
// FAKENECT_PATH=<dump>): only the 11-bit depth mode and RGB video mode are asked for, and
// functions fakenect lacks are declared weak and skipped when absent.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/driver/device_clock.h"
#include "shapesense/driver/kinect_raw.h"
#include "shapesense/driver/live_sources_device.h"

namespace shapesense {

/// Which Kinect: by camera serial (as printed by `freenect-camtest` or lsusb -v) or by index
/// in libfreenect's enumeration order.
struct FreenectDeviceSelector {
  std::string serial;  ///< non-empty: open this serial. Default empty.
  int index = 0;       ///< used when serial is empty. Default 0 (the first Kinect).

  /// "" -> index 0; up to three digits -> that index; anything else -> a serial.
  static FreenectDeviceSelector parse(const std::string& text);
  /// "0" or the serial.
  std::string toString() const;
};

struct FreenectOptions {
  FreenectDeviceSelector device{};  ///< Default: the first Kinect.
  bool colour = true;               ///< also stream RGB. Default true.
  KinectRawParams raw{};            ///< raw -> mm conversion. Default: kinect_raw.h.
  CameraIntrinsics intrinsics{};  ///< of the depth camera. Default: Kinect v1 525/525/319.5/239.5.
  /// Device counter. Default: 32 bits at 60 MHz. (The window etc. can be tuned here.)
  DeviceClockParams clock{};
  LiveSourceOptions live{};  ///< timeouts, reopening, queue. Defaults: see LiveSourceOptions.
};

/// "freenect:<selector>" source. Construction never fails for a missing sensor: it waits for
/// one (connected() is false meanwhile, and next() reports it once as SourceError).
class FreenectSource final : public LiveSource {
 public:
  explicit FreenectSource(FreenectOptions options = {});
};

/// The connector behind FreenectSource (exposed for tests).
std::unique_ptr<DeviceConnector> makeFreenectConnector(FreenectOptions options);

}  // namespace shapesense
