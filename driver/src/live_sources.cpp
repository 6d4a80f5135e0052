#include "shapesense/driver/live_sources.h"

#include <stdexcept>

#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/freenect_source.h"
#include "shapesense/driver/openni2_source.h"

namespace shapesense {

std::unique_ptr<FrameSource> openLiveSource(const std::string& kind, const std::string& argument) {
  if (kind == "freenect") {
    FreenectOptions options;
    options.device = FreenectDeviceSelector::parse(argument);
    return std::make_unique<FreenectSource>(options);
  }
  if (kind == "openni2") {
    OpenNI2Options options;
    options.uri = argument;
    return std::make_unique<OpenNI2Source>(options);
  }
  if (kind == "fakenect") {
    if (argument.empty())
      throw std::invalid_argument("--source fakenect:DIR needs a dump directory");
    return std::make_unique<FakenectDumpSource>(argument);
  }
  return nullptr;
}

}  // namespace shapesense
