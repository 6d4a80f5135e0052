// fakenect PGM / PPM frames. The first byte picks depth or colour and whether the rest is padded
// with zeros to a full 640x480 payload, so the pixel checks are reached without megabyte inputs.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "shapesense/driver/fakenect_dump.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool depth = data[0] & 1;
  const bool pad = data[0] & 2;
  std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::size_t payload =
      std::size_t{shapesense::kFakenectWidth} * shapesense::kFakenectHeight * (depth ? 2 : 3);
  if (pad) bytes.resize(bytes.size() + payload, '\0');
  try {
    if (depth) {
      shapesense::decodeFakenectDepth(bytes, "d.pgm");
    } else {
      shapesense::decodeFakenectRgb(bytes, "r.ppm");
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
