#pragma once
// Factory for the live-sensor and fakenect --source specs, called by openSource (open_source.h):
//   freenect[:SERIAL|INDEX]   Kinect v1 via libfreenect (INDEX = up to 3 digits; default 0)
//   openni2[:URI]             OpenNI2 device (default: the first one), e.g. openni2:Dummy
//   fakenect:DIR              a libfreenect `record` dump, replayed by this project's reader
// Live sources wait for a missing sensor instead of failing; see FreenectSource /
// OpenNI2Source for their connected() state.

#include <memory>
#include <string>

#include "shapesense/driver/frame_source.h"

namespace shapesense {

/// The source for `kind` ("freenect", "openni2", "fakenect") with the text after the colon as
/// `argument`; nullptr for any other kind. Throws std::invalid_argument for a bad argument
/// (fakenect without a directory) and std::runtime_error when a dump cannot be read.
std::unique_ptr<FrameSource> openLiveSource(const std::string& kind, const std::string& argument);

}  // namespace shapesense
