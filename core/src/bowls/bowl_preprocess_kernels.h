#pragma once
// The SIMD kernels of the bowl detector's preprocessing (Google Highway, dispatched at run time
// to the best target the CPU has): the hole fill of fillInvalidRecursiveMedian and the row
// codes of lbpCodeImage. Integer work only, so every target computes the same bits.

#include <cstdint>

namespace shapesense::bowls {

/// One pass of the recursive median fill over one row (see depth_preprocess.cpp): fills the
/// holes of `here` in scan order (forward: left to right) from the rows `above` and `below`
/// (rows outside the image: all 0, cols + 16 long). Returns the number of pixels filled.
int fillHolesInRow(const std::uint16_t* above, std::uint16_t* here, const std::uint16_t* below,
                   int cols, bool forward);

/// LBP codes of `out_cols` grid positions of one row, from the cell sums of the grid's three
/// cell rows (`r0`, `r1`, `r2`: sums of the cells starting at each x; cells `cw` wide): bit k
/// is set when neighbour k (clockwise from the top-left) has a sum >= the centre's.
void lbpCodeRow(const std::int16_t* r0, const std::int16_t* r1, const std::int16_t* r2, int cw,
                std::uint8_t* out, int out_cols);

}  // namespace shapesense::bowls
