#include "shapesense/core/geometry/order_statistics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace shapesense {

double quantile(std::vector<double>& values, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<std::size_t>(k)];
}

namespace {

// Bins of the histogram that narrows a rank down before the exact selection; enough that the
// values sharing the rank's bin are a small fraction of a frame.
constexpr std::size_t kBins = 4096;

// Where a rank falls: its bin, and its rank among the values of that bin.
struct RankInBin {
  std::size_t bin = 0;
  std::size_t rank = 0;
};

RankInBin locate(const std::array<std::size_t, kBins>& counts, std::size_t rank) {
  std::size_t bin = 0;
  while (counts[bin] <= rank) rank -= counts[bin++];
  return {bin, rank};
}

double select(std::vector<double>& in_bin, std::size_t rank) {
  const auto k = static_cast<std::ptrdiff_t>(rank);
  std::nth_element(in_bin.begin(), in_bin.begin() + k, in_bin.end());
  return in_bin[rank];
}

}  // namespace

std::pair<double, double> trimmedRange(std::span<const double> values, double trim) {
  const std::size_t n = values.size();
  const auto low_rank = static_cast<std::size_t>(std::floor(trim * static_cast<double>(n)));
  const std::size_t high_rank = n - 1 - low_rank;
  const auto [min_it, max_it] = std::minmax_element(values.begin(), values.end());
  const double lowest = *min_it, highest = *max_it;
  if (low_rank == 0 || highest == lowest) return {lowest, highest};
  // Monotone in the value, so the bins are in the values' order and a rank falls in one bin.
  const double scale = static_cast<double>(kBins) / (highest - lowest);
  std::vector<std::uint16_t> bin_of(n);
  std::array<std::size_t, kBins> counts{};
  for (std::size_t i = 0; i < n; ++i) {
    bin_of[i] = static_cast<std::uint16_t>(
        std::min(kBins - 1, static_cast<std::size_t>((values[i] - lowest) * scale)));
    ++counts[bin_of[i]];
  }
  const RankInBin low = locate(counts, low_rank), high = locate(counts, high_rank);
  std::vector<double> low_bin, high_bin;
  low_bin.reserve(counts[low.bin]);
  high_bin.reserve(counts[high.bin]);
  for (std::size_t i = 0; i < n; ++i) {
    if (bin_of[i] == low.bin) low_bin.push_back(values[i]);
    if (bin_of[i] == high.bin) high_bin.push_back(values[i]);
  }
  return {select(low_bin, low.rank), select(high_bin, high.rank)};
}

std::pair<double, double> denseRange(std::span<const double> values, double max_gap,
                                     double min_share) {
  const auto [min_it, max_it] = std::minmax_element(values.begin(), values.end());
  const double lowest = *min_it, highest = *max_it;
  // Bins half the gap wide, fewer than a bound a stray value far off cannot push past.
  constexpr double kMaxBins = 1 << 16;
  const double width = std::max(0.5 * max_gap, (highest - lowest) / kMaxBins);
  if (!(highest - lowest > width)) return {lowest, highest};
  const auto bins = static_cast<std::size_t>((highest - lowest) / width) + 1;
  const double scale = 1.0 / width;
  const auto binOf = [&](double value) {
    return std::min(bins - 1, static_cast<std::size_t>((value - lowest) * scale));
  };
  std::vector<std::size_t> counts(bins, 0);
  for (const double value : values) ++counts[binOf(value)];
  // Clusters: runs of non-empty bins. Kept: the median's, and every one holding min_share.
  const double needed = min_share * static_cast<double>(values.size());
  std::size_t first = bins, last = 0, seen = 0;
  for (std::size_t begin = 0; begin < bins;) {
    if (counts[begin] == 0) {
      ++begin;
      continue;
    }
    std::size_t end = begin, held = 0;
    while (end < bins && counts[end] > 0) held += counts[end++];
    const bool holds_median = seen <= values.size() / 2 && values.size() / 2 < seen + held;
    if (holds_median || static_cast<double>(held) >= needed) {
      first = std::min(first, begin);
      last = std::max(last, end - 1);
    }
    seen += held;
    begin = end;
  }
  if (first == 0 && last == bins - 1) return {lowest, highest};
  double low = highest, high = lowest;
  for (const double value : values) {
    const std::size_t bin = binOf(value);
    if (bin < first || bin > last) continue;
    low = std::min(low, value);
    high = std::max(high, value);
  }
  return {low, high};
}

double bucketQuantile(std::span<const double> upper_bounds, std::span<const std::uint64_t> counts,
                      double q) {
  std::uint64_t total = 0;
  for (const std::uint64_t n : counts) total += n;
  if (total == 0) return 0;
  const std::uint64_t wanted = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(total))));
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    seen += counts[i];
    if (seen >= wanted) {
      return i < upper_bounds.size() ? upper_bounds[i] : std::numeric_limits<double>::infinity();
    }
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace shapesense
