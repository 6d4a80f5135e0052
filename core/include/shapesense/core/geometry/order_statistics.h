#pragma once
// Quantiles of a set of values, the one implementation core/ uses: the bowl check's percentiles
// over a few hundred values and a box's trimmed extents over up to a whole frame of points; and
// of values known only as counts per bucket (the daemon's call latencies).

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace shapesense {

/// The value at rank floor(q * (n - 1)) of `values` (q in 0..1), which it reorders. n > 0.
double quantile(std::vector<double>& values, double q);

/// The values at ranks floor(trim * n) and n - 1 - floor(trim * n): the range of `values` after
/// dropping `trim` (0 <= trim < 0.5) of them at each end. Exact, in two passes over the values
/// and a selection within the histogram bins that hold those ranks, so a frame-sized set costs
/// about as much as reading it twice. n > 0.
std::pair<double, double> trimmedRange(std::span<const double> values, double trim);

/// The range of the dense body of `values`, without sparse stragglers beyond a gap (the wall
/// seen past an object's edge, a trail of flying pixels behind it). The values fall into
/// clusters separated by empty stretches wider than `max_gap`; the range spans the cluster that
/// holds the median and every cluster holding at least `min_share` of the values (several
/// objects in one set stay together). Found on a histogram of bins max_gap / 2 wide, split at
/// empty bins, so a gap wider than `max_gap` always separates and one over half of it may.
/// Exact ends (the outermost values kept). n > 0, max_gap > 0.
std::pair<double, double> denseRange(std::span<const double> values, double max_gap,
                                     double min_share);

/// The upper bound of the bucket in which the share `q` (0..1) of the counted values is reached:
/// an upper estimate of their q-quantile. counts[i] counts values up to upper_bounds[i]; one more
/// count than bounds takes the values above the last bound, and +inf stands for them. 0 when
/// nothing is counted.
double bucketQuantile(std::span<const double> upper_bounds, std::span<const std::uint64_t> counts,
                      double q);

}  // namespace shapesense
