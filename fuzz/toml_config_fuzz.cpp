// The daemon's --config file: CLI11's TOML reader, with options of the kinds shapesensed declares
// (server/src/main.cpp: strings, checked sets, a range-checked integer, a flag).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  CLI::App app{"fuzz"};
  std::string source, rate = "recorded", listen, models;
  bool loop = false;
  std::size_t cache_frames = 300;
  app.add_option("--source", source);
  app.add_option("--rate", rate)->check(CLI::IsMember({"recorded", "max"}));
  app.add_flag("--loop", loop);
  app.add_option("--cache-frames", cache_frames)->check(CLI::Range(1, 100000));
  app.add_option("--listen", listen);
  app.add_option("--models", models);
  std::istringstream input(std::string(reinterpret_cast<const char*>(data), size));
  try {
    app.parse_from_stream(input);
  } catch (const CLI::Error&) {
  }
  return 0;
}
