#pragma once
// The SIMD kernels of the bowl detector's preprocessing (Google Highway, dispatched at run time
// to the best target the CPU has): the hole fill of fillInvalidRecursiveMedian, the 8-bit depth
// mapping and the row codes of lbpCodeImage. Integer work, and double arithmetic with the
// scalar code's operations in its order (no fused multiply-add: -ffp-contract=off), so every
// target computes the same bits.

#include <cstdint>

namespace shapesense::bowls {

/// One pass of the recursive median fill over one row (see depth_preprocess.cpp): fills the
/// holes of `here` in scan order (forward: left to right) from the rows `above` and `below`
/// (rows outside the image: all 0, cols + 16 long). Returns the number of pixels filled.
int fillHolesInRow(const std::uint16_t* above, std::uint16_t* here, const std::uint16_t* below,
                   int cols, bool forward);

/// The linear part of DepthTo8BitMap: depth v (mm) in [lo_end, hi_begin) maps to
/// round(low + (v - near_mm) * gain), below to `low`, above to `high`, and 0 to `unfilled`.
struct LinearDepthMap {
  double near_mm = 0, gain = 0;
  int low = 0, high = 0, unfilled = 0;
  int lo_end = 1, hi_begin = 65536;
};

/// Maps the first `n` depths of `in` (mm) to `out` by `m`. Returns how many it mapped: a whole
/// number of vectors; the caller maps the rest.
int mapDepthRowTo8Bit(const std::uint16_t* in, std::uint8_t* out, int n, const LinearDepthMap& m);

/// LBP codes of `out_cols` grid positions of one row, from the cell sums of the grid's three
/// cell rows (`r0`, `r1`, `r2`: sums of the cells starting at each x; cells `cw` wide): bit k
/// is set when neighbour k (clockwise from the top-left) has a sum >= the centre's.
void lbpCodeRow(const std::int16_t* r0, const std::int16_t* r1, const std::int16_t* r2, int cw,
                std::uint8_t* out, int out_cols);

}  // namespace shapesense::bowls
