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

/// Whether a frame captured at `t` may come after one captured at `previous`: capture times
/// strictly increase. The one rule of the daemon's cache and of every replay (tum_recording.h),
/// so a recording's frames are the frames a daemon replaying it keeps, and "the frame at T" is
/// never two frames.
constexpr bool stampFollows(TimestampNs previous, TimestampNs t) { return t > previous; }

/// Formats nanoseconds as seconds with `decimals` fractional digits (0-9), rounding.
std::string formatNsAsSeconds(TimestampNs ns, int decimals = 6);

}  // namespace shapesense
