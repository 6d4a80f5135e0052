#include "time_arg.h"

#include <CLI/CLI.hpp>

#include "shapesense/core/geometry/timestamp.h"

namespace shapesense::cli {

TimestampNs parseTimeArgument(const std::string& text) {
  if (text.empty() || text == "latest" || text == "now") return 0;
  const auto ns = parseSecondsToNs(text);
  if (!ns || *ns < 0) {
    throw CLI::ValidationError("--at", "'" + text +
                                           "' is not a time: give seconds since the epoch such "
                                           "as 1700000000.033333, or 'latest'");
  }
  return *ns;
}

}  // namespace shapesense::cli
