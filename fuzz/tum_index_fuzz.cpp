// depth.txt / rgb.txt: any bytes give entries and problems, and every problem stays short.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "shapesense/driver/tum_recording.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> problems;
  const bool in_time_order = size > 0 && (data[0] & 1);
  const auto entries = shapesense::parseTumIndexText(text, "depth.txt", in_time_order, problems);
  for (const auto& problem : problems) {
    if (problem.size() > 512) std::abort();  // a bad line is quoted short
  }
  for (std::size_t i = 1; in_time_order && i < entries.size(); ++i) {
    if (entries[i].timestamp_ns < entries[i - 1].timestamp_ns) std::abort();
  }
  return 0;
}
