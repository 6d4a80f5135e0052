// fakenect INDEX.txt: any bytes give entries inside the dump and short problems.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "shapesense/driver/bounded_file.h"
#include "shapesense/driver/fakenect_dump.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto index = shapesense::parseFakenectIndexText(text, "INDEX.txt");
  for (const auto& problem : index.problems) {
    if (problem.size() > 512) std::abort();
  }
  for (const auto& entry : index.entries) {
    if (!shapesense::isPlainRelativePath(entry.file_name)) std::abort();
  }
  return 0;
}
