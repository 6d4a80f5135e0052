#pragma once
// The SIMD kernel of the bowl detector's window scan (Google Highway, dispatched at run time):
// the first two cascade stages over the windows of one row. Integer work only, so every target
// computes the same bits as the scalar loop of scanLevel.

#include <cstddef>
#include <cstdint>

namespace shapesense::bowls {

/// One row of windows at x = i * 2 (the detector's default stride), i in [0, windows), going
/// through the depth gate and the first two stages, which read code images.
struct FirstStagesRow {
  const std::uint8_t* codes0 = nullptr;  ///< stage 0's code row: the code of window x at x
  const std::uint8_t* codes1 = nullptr;  ///< stage 1's
  const std::int32_t* lut0 = nullptr;    ///< stage 0's votes, 256 entries
  const std::int32_t* lut1 = nullptr;
  std::int32_t threshold0 = 0, threshold1 = 0;  ///< running score must stay at or above
  const std::uint8_t* in_gate = nullptr;        ///< per window: 1 in the depth gate, 0 not
  std::size_t windows = 0;
};

/// Compacts the windows of a whole number of vectors from the row start that pass the gate
/// and both stages into `alive_x` (their x) and `alive_score` (their score after stage 1), in
/// order; both arrays hold `windows` entries. Returns {windows processed, windows kept}; the
/// caller goes on from the first unprocessed window.
struct FirstStagesResult {
  std::size_t processed = 0, kept = 0;
};
FirstStagesResult firstStagesStride2(const FirstStagesRow& row, int* alive_x,
                                     std::int32_t* alive_score);

}  // namespace shapesense::bowls
