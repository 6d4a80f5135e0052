#pragma once
// Quantiles of a set of values, the one implementation core/ uses: the bowl check's percentiles
// over a few hundred values and a box's trimmed extents over up to a whole frame of points.

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

}  // namespace shapesense
