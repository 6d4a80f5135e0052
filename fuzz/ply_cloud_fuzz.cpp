// PLY point clouds: any bytes give either a cloud within the limit, every point finite and
// normals one per point or none, or PlyFileError; never another exception or a large allocation
// (libFuzzer's -rss_limit_mb catches one).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "shapesense/driver/ply_cloud.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kMaxPoints = 100'000;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    const shapesense::PointCloudFile cloud =
        shapesense::parsePlyCloud(bytes, "fuzz.ply", kMaxPoints);
    if (cloud.points.size() > kMaxPoints) std::abort();
    if (!cloud.normals.empty() && cloud.normals.size() != cloud.points.size()) std::abort();
    for (const auto& p : cloud.points)
      if (!p.allFinite()) std::abort();
  } catch (const shapesense::PlyFileError& e) {
    // A message quotes the file's bytes short.
    if (std::string_view(e.what()).size() > 512) std::abort();
  }
  return 0;
}
