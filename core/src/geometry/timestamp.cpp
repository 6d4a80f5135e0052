#include "shapesense/core/geometry/timestamp.h"

#include <cstdint>
#include <cstdio>
#include <limits>

namespace shapesense {

std::optional<TimestampNs> parseSecondsToNs(std::string_view text) {
  if (text.empty()) return std::nullopt;
  bool negative = false;
  if (text.front() == '-' || text.front() == '+') {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  const auto dot = text.find('.');
  const std::string_view whole = text.substr(0, dot);
  const std::string_view frac = dot == std::string_view::npos ? "" : text.substr(dot + 1);
  if (whole.empty() && frac.empty()) return std::nullopt;

  constexpr std::int64_t kMaxSeconds = std::numeric_limits<std::int64_t>::max() / 1'000'000'000 - 1;
  std::int64_t seconds = 0;
  for (char c : whole) {
    if (c < '0' || c > '9') return std::nullopt;
    seconds = seconds * 10 + (c - '0');
    if (seconds > kMaxSeconds) return std::nullopt;
  }
  std::int64_t nanos = 0;
  int digits = 0;
  bool round_up = false;
  for (char c : frac) {
    if (c < '0' || c > '9') return std::nullopt;
    if (digits < 9) {
      nanos = nanos * 10 + (c - '0');
    } else if (digits == 9) {
      round_up = c >= '5';
    }
    ++digits;
  }
  for (; digits < 9; ++digits) nanos *= 10;
  std::int64_t total = seconds * 1'000'000'000 + nanos + (round_up ? 1 : 0);
  return negative ? -total : total;
}

std::string formatNsAsSeconds(TimestampNs ns, int decimals) {
  if (decimals < 0) decimals = 0;
  if (decimals > 9) decimals = 9;
  const bool negative = ns < 0;
  // Work on the magnitude as unsigned so INT64_MIN stays defined.
  std::uint64_t magnitude =
      negative ? 0 - static_cast<std::uint64_t>(ns) : static_cast<std::uint64_t>(ns);
  std::uint64_t unit = 1;
  for (int i = decimals; i < 9; ++i) unit *= 10;
  magnitude = (magnitude + unit / 2) / unit;  // round to the requested digits
  std::uint64_t scale = 1;
  for (int i = 0; i < decimals; ++i) scale *= 10;
  const std::uint64_t whole = magnitude / scale;
  const std::uint64_t frac = magnitude % scale;
  char buf[48];
  if (decimals == 0) {
    std::snprintf(buf, sizeof buf, "%s%llu", negative ? "-" : "",
                  static_cast<unsigned long long>(whole));
  } else {
    std::snprintf(buf, sizeof buf, "%s%llu.%0*llu", negative ? "-" : "",
                  static_cast<unsigned long long>(whole), decimals,
                  static_cast<unsigned long long>(frac));
  }
  return buf;
}

}  // namespace shapesense
