// camera.json: any bytes give either intrinsics inside the documented ranges or CameraFileError.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "shapesense/driver/camera_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto camera = shapesense::parseRecordingCamera(text, "camera.json");
    const auto& k = camera.intrinsics;
    const bool sane = k.width >= 1 && k.width <= shapesense::kMaxImageSide && k.height >= 1 &&
                      k.height <= shapesense::kMaxImageSide && std::isfinite(k.fx) && k.fx > 0.0 &&
                      k.fx <= shapesense::kMaxFocalPx && std::isfinite(k.fy) && k.fy > 0.0 &&
                      k.fy <= shapesense::kMaxFocalPx && k.cx >= 0.0 && k.cx <= k.width &&
                      k.cy >= 0.0 && k.cy <= k.height &&
                      camera.depth_scale >= shapesense::kMinDepthScale &&
                      camera.depth_scale <= shapesense::kMaxDepthScale;
    if (!sane) std::abort();
  } catch (const shapesense::CameraFileError&) {
  }
  return 0;
}
