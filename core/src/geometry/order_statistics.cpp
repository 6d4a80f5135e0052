#include "shapesense/core/geometry/order_statistics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

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

// The value of rank `rank` among `values`, given their histogram: only the values in the bin
// holding that rank are ordered.
template <typename BinOf>
double valueOfRank(std::span<const double> values, const std::array<std::size_t, kBins>& counts,
                   std::size_t rank, const BinOf& bin_of) {
  std::size_t bin = 0, before = 0;
  while (before + counts[bin] <= rank) before += counts[bin++];
  std::vector<double> in_bin;
  in_bin.reserve(counts[bin]);
  for (const double v : values)
    if (bin_of(v) == bin) in_bin.push_back(v);
  const auto k = static_cast<std::ptrdiff_t>(rank - before);
  std::nth_element(in_bin.begin(), in_bin.begin() + k, in_bin.end());
  return in_bin[static_cast<std::size_t>(k)];
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
  const auto bin_of = [&](double v) {
    return std::min(kBins - 1, static_cast<std::size_t>((v - lowest) * scale));
  };
  std::array<std::size_t, kBins> counts{};
  for (const double v : values) ++counts[bin_of(v)];
  return {valueOfRank(values, counts, low_rank, bin_of),
          valueOfRank(values, counts, high_rank, bin_of)};
}

}  // namespace shapesense
