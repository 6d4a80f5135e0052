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

/// The 8-bit depth mapping in fixed point (DepthTo8BitMap uses it where it gives every value of
/// its table): 0 -> `unfilled`; (0, ramp_begin) -> `low`; [ramp_begin, ramp_end) ->
/// (v * gain + offset) >> shift; ramp_end and above -> `high`. ramp_end * gain + offset must
/// fit in 31 bits.
struct FixedPointDepthMap {
  std::int32_t ramp_begin = 1, ramp_end = 1;
  std::int32_t gain = 0, offset = 0;
  int shift = 0;
  std::uint8_t low = 0, high = 0, unfilled = 0;
  std::uint8_t at(std::uint16_t v) const {
    if (v == 0) return unfilled;
    if (v < ramp_begin) return low;
    if (v >= ramp_end) return high;
    return static_cast<std::uint8_t>((v * gain + offset) >> shift);
  }
};

/// out[u] = map.at(depth[u]) for u in [0, cols).
void mapDepthRow(const std::uint16_t* depth, int cols, const FixedPointDepthMap& map,
                 std::uint8_t* out);

}  // namespace shapesense::bowls
