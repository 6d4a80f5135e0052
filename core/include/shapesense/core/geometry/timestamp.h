#pragma once
// Exact conversions between decimal-seconds text ("1700000000.033333", as TUM recordings
// write it) and integer nanoseconds. Going through double would lose ~100 ns at epoch scale.

#include <optional>
#include <string>
#include <string_view>

#include "shapesense/core/geometry/frame.h"

namespace shapesense {

/// Parses "[-]S[.F]" seconds into nanoseconds; digits past the 9th fractional digit are
/// rounded. Returns nullopt on anything else (empty, letters, exponent, overflow).
std::optional<TimestampNs> parseSecondsToNs(std::string_view text);

/// Formats nanoseconds as seconds with `decimals` fractional digits (0-9), rounding.
std::string formatNsAsSeconds(TimestampNs ns, int decimals = 6);

}  // namespace shapesense
