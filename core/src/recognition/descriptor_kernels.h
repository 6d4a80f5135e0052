#pragma once
// The SIMD kernel of descriptor matching (Google Highway, dispatched at run time): squared
// Euclidean distances from one shape descriptor to many. Each lane holds one distance, summed
// over the dimensions in order, without fused multiply-adds: every target computes the bits of
// the scalar loop.

#include <cstddef>

#include "shapesense/core/recognition/shape_features.h"

namespace shapesense::detail {

/// For each of `query_count` queries q: out[q * count + i] = sum over d of
/// (queries[q][d] - columns[d * count + i])^2, d from 0 up, for i < count: `columns` holds
/// `count` descriptors transposed (dimension-major).
void squaredDistancesToAll(const float* const* queries, std::size_t query_count,
                           const float* columns, std::size_t count, float* out);

}  // namespace shapesense::detail
