#pragma once
// Command-line time arguments: "--at T" as decimal seconds, as recordings write them.

#include <string>

#include "shapesense/core/geometry/frame.h"

namespace shapesense::cli {

/// Parses T given as seconds ("1700000000.033333"), "now"/"latest" (0 = the newest frame).
/// Throws CLI::ValidationError with a message naming the bad text.
TimestampNs parseTimeArgument(const std::string& text);

}  // namespace shapesense::cli
