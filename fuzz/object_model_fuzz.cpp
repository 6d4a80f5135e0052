// Object model JSON (a taught object's file in the daemon's models folder) through the parser
// the loader uses, with the default descriptor parameters.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "shapesense/core/recognition/object_model_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    shapesense::parseObjectModel(std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const std::runtime_error&) {
  }
  return 0;
}
