// The bowl preprocessing kernels, written once with Google Highway (see
// bowl_preprocess_kernels.h).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "bowls/bowl_preprocess_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// Highway's foreach_target must come before highway.h.
#include <hwy/highway.h>

#include <algorithm>

#include "bowls/bowl_preprocess_kernels.h"

// The fill works on blocks of 8 pixels of a row. A hole pixel's lower median depends on one
// neighbour the scan has just filled (forward: the left one, backward: the right one); its
// other 7 neighbours are already final (the row behind the scan) or not yet touched in this
// pass (the row ahead, the pixel ahead in the row). So the 7 known neighbours of 8 pixels are
// sorted together in vector lanes, and only the last step is serial: with s the m valid known
// values sorted ascending and L the just-filled neighbour, the lower median of the n = m + 1
// valid values (index m / 2) is clamp(L, s[m/2 - 1], s[m/2]); when L is invalid it is s[(m-1)/2]
// of the m values alone. That is the same value a median of the 8 neighbours gives, at a
// fraction of the cost per pixel, which matters in the large holes of real frames (shadows,
// out-of-range areas) where every pixel is filled.
//
// Values are compared in an "ordered" 16-bit signed form t = (v - 1) ^ 0x8000: valid depths
// 1..65535 map in order to -32768..32766 and the invalid 0 maps to 32767 (kInvalid), above
// every valid value, so the invalid neighbours sort last and signed min/max apply.

HWY_BEFORE_NAMESPACE();
namespace shapesense::bowls {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

constexpr std::int16_t kInvalid = 0x7FFF;
constexpr int kBlock = 8;  // pixels per block

inline std::int16_t toOrdered(std::uint16_t v) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(v - 1) ^ 0x8000);
}
inline std::uint16_t fromOrdered(std::int16_t t) {
  return static_cast<std::uint16_t>((static_cast<std::uint16_t>(t) ^ 0x8000) + 1);
}

/// For the 8 pixels of a block: the bounds lo, hi of the clamp and the median mid without the
/// serial neighbour (see above), in the ordered form. mid = kInvalid when a pixel has no valid
/// known neighbour.
struct BlockStats {
  std::int16_t lo[kBlock];
  std::int16_t hi[kBlock];
  std::int16_t mid[kBlock];
};

/// Up to 8 lanes: one vector per block where the target has 128-bit vectors.
using BlockTag = hn::CappedTag<std::int16_t, kBlock>;

/// blockStats for pixels j .. j + Lanes(d) of the block.
void blockStatsLanes(BlockTag d, const std::uint16_t* above, const std::uint16_t* here_known,
                     const std::uint16_t* below, int j, BlockStats& out) {
  using V = hn::Vec<BlockTag>;
  const hn::RebindToUnsigned<BlockTag> du;
  auto load = [&](const std::uint16_t* p) {
    return hn::BitCast(d,
                       hn::Xor(hn::Sub(hn::LoadU(du, p + j), hn::Set(du, 1)), hn::Set(du, 0x8000)));
  };
  V s[7] = {load(above), load(above + 1), load(above + 2), load(here_known),
            load(below), load(below + 1), load(below + 2)};
  // Optimal 16-comparator network for 7 elements (checked on all 0/1 inputs).
  auto exchange = [&s](int i, int k) {
    const V lo = hn::Min(s[i], s[k]);
    s[k] = hn::Max(s[i], s[k]);
    s[i] = lo;
  };
  exchange(0, 6), exchange(2, 3), exchange(4, 5);
  exchange(0, 2), exchange(1, 4), exchange(3, 6);
  exchange(0, 1), exchange(2, 5), exchange(3, 4);
  exchange(1, 2), exchange(4, 6);
  exchange(2, 3), exchange(4, 5);
  exchange(1, 2), exchange(3, 4), exchange(5, 6);
  // Invalid values sort last, so s[i] is invalid exactly when i >= m. Selecting by m:
  //   hi  = s[m/2]:          s0, s1 from m >= 2, s2 from m >= 4, s3 from m >= 6;
  //   lo  = s[m/2 - 1]:      lowest for m < 2, s0 from m >= 2, s1 from 4, s2 from 6;
  //   mid = s[(m - 1) / 2]:  s0 (invalid when m = 0), s1 from m >= 3, s2 from 5, s3 from 7.
  const V invalid = hn::Set(d, kInvalid);
  auto atLeast = [&](int m) { return hn::Not(hn::Eq(s[m - 1], invalid)); };  // m valid
  const auto m2 = atLeast(2), m3 = atLeast(3), m4 = atLeast(4), m5 = atLeast(5), m6 = atLeast(6),
             m7 = atLeast(7);
  const V hi = hn::IfThenElse(m6, s[3], hn::IfThenElse(m4, s[2], hn::IfThenElse(m2, s[1], s[0])));
  const V lo = hn::IfThenElse(
      m6, s[2], hn::IfThenElse(m4, s[1], hn::IfThenElse(m2, s[0], hn::Set(d, -32768))));
  const V mid = hn::IfThenElse(m7, s[3], hn::IfThenElse(m5, s[2], hn::IfThenElse(m3, s[1], s[0])));
  hn::StoreU(lo, d, out.lo + j);
  hn::StoreU(hi, d, out.hi + j);
  hn::StoreU(mid, d, out.mid + j);
}

/// `above`, `here`, `below` point at column c - 1 of the three rows (columns c - 1 .. c + 8
/// readable); the 8 pixels are columns c .. c + 7 of `here`. Forward: the known horizontal
/// neighbour is the right one (c + 1), backward the left one (c - 1).
template <bool Forward>
void blockStats(const std::uint16_t* above, const std::uint16_t* here, const std::uint16_t* below,
                BlockStats& out) {
  const BlockTag d;
  const int n = static_cast<int>(hn::Lanes(d));
  for (int j = 0; j < kBlock; j += n)
    blockStatsLanes(d, above, Forward ? here + 2 : here, below, j, out);
}

/// True when one of columns c .. c + 7 of `row` is 0.
bool anyHole(const std::uint16_t* row, int c) {
  const hn::CappedTag<std::uint16_t, kBlock> d;
  const int n = static_cast<int>(hn::Lanes(d));
  for (int j = 0; j < kBlock; j += n)
    if (!hn::AllFalse(d, hn::Eq(hn::LoadU(d, row + c + j), hn::Zero(d)))) return true;
  return false;
}

/// True when columns c - 1 .. c + 8 of the three rows hold no valid pixel.
bool noValidAround(const std::uint16_t* above, const std::uint16_t* here,
                   const std::uint16_t* below, int c) {
  const hn::CappedTag<std::uint16_t, kBlock> d;
  const int n = static_cast<int>(hn::Lanes(d));
  for (int j = 0; j < kBlock; j += n) {
    auto load = [&](const std::uint16_t* p) { return hn::LoadU(d, p + j); };
    const auto any =
        hn::Or(hn::Or(hn::Or(load(above + c - 1), load(here + c - 1)), load(below + c - 1)),
               hn::Or(hn::Or(load(above + c + 1), load(here + c + 1)), load(below + c + 1)));
    if (!hn::AllTrue(d, hn::Eq(any, hn::Zero(d)))) return false;
  }
  return true;
}

/// The serial step over the n pixels of a block in scan order; `L` is the serial neighbour's
/// value. Returns the number of pixels filled.
template <bool Forward>
int fillBlock(const BlockStats& st, std::uint16_t* here, int c, int n, std::int16_t L) {
  int filled = 0;
  // Without branches: holes and valid pixels alternate unpredictably at a hole's edge.
  for (int k = 0; k < n; ++k) {
    const int i = Forward ? k : n - 1 - k;
    const std::uint16_t v = here[c + i];
    // On values, not std::min/max's references: a select of addresses puts a load in the
    // chain from one pixel to the next.
    const std::int16_t lo = st.lo[i], hi = st.hi[i], mid = st.mid[i];
    const std::int16_t below_hi = L < hi ? L : hi;
    const std::int16_t median = L == kInvalid ? mid : (below_hi > lo ? below_hi : lo);
    const bool hole = v == 0;
    const bool fills = hole & (median != kInvalid);
    here[c + i] = fills ? fromOrdered(median) : v;
    filled += fills;
    L = hole ? median : toOrdered(v);
  }
  return filled;
}

/// One pass over one row: fills the holes of columns [c, c + 8) ∩ [0, cols) block by block in
/// scan order. Returns the number of pixels filled.
template <bool Forward>
int fillRow(const std::uint16_t* above, std::uint16_t* here, const std::uint16_t* below, int cols) {
  int filled = 0;
  const int blocks = (cols + kBlock - 1) / kBlock;
  BlockStats st;
  for (int b = 0; b < blocks; ++b) {
    const int c = kBlock * (Forward ? b : blocks - 1 - b);
    const int n = std::min(kBlock, cols - c);  // pixels in this block
    // The serial neighbour's value: final already (it lies behind the scan).
    const int serial_col = Forward ? c - 1 : c + n;
    const std::int16_t L =
        serial_col >= 0 && serial_col < cols ? toOrdered(here[serial_col]) : kInvalid;
    const bool interior = c >= 1 && c + 9 <= cols;
    if (interior) {
      if (!anyHole(here, c)) continue;
      // Inside a large hole with nothing valid near: every pixel stays invalid this pass.
      if (L == kInvalid && noValidAround(above, here, below, c)) continue;
      blockStats<Forward>(above + c - 1, here + c - 1, below + c - 1, st);
    } else {
      // Image border or row end: a copy of columns c - 1 .. c + 8 with 0 (invalid) outside.
      std::uint16_t pad[3][16] = {};
      const std::uint16_t* rows[3] = {above, here, below};
      for (int k = 0; k < 3; ++k)
        for (int x = std::max(0, c - 1); x <= std::min(cols - 1, c + 8); ++x)
          pad[k][x - (c - 1)] = rows[k][x];
      bool any_hole = false;
      for (int i = 0; i < n; ++i) any_hole |= here[c + i] == 0;
      if (!any_hole) continue;
      blockStats<Forward>(pad[0], pad[1], pad[2], st);
    }
    filled += fillBlock<Forward>(st, here, c, n, L);
  }
  return filled;
}

int FillHolesInRow(const std::uint16_t* above, std::uint16_t* here, const std::uint16_t* below,
                   int cols, bool forward) {
  return forward ? fillRow<true>(above, here, below, cols)
                 : fillRow<false>(above, here, below, cols);
}

void LbpCodeRow(const std::int16_t* r0, const std::int16_t* r1, const std::int16_t* r2, int cw,
                std::uint8_t* out, int out_cols) {
  int x = 0;
#if HWY_TARGET != HWY_SCALAR  // 16-bit codes demoted to bytes
  const hn::ScalableTag<std::int16_t> d;
  const hn::Rebind<std::uint8_t, decltype(d)> d8;
  const int n = static_cast<int>(hn::Lanes(d));
  for (; x + n <= out_cols; x += n) {
    const auto centre = hn::LoadU(d, r1 + x + cw);
    // Bit k where neighbour k is not below the centre.
    auto bit = [&](const std::int16_t* p, int k) {
      return hn::IfThenZeroElse(hn::Lt(hn::LoadU(d, p + x), centre),
                                hn::Set(d, static_cast<std::int16_t>(1 << k)));
    };
    const auto top = hn::Or(hn::Or(bit(r0, 0), bit(r0 + cw, 1)),
                            hn::Or(bit(r0 + 2 * cw, 2), bit(r1 + 2 * cw, 3)));
    const auto bottom =
        hn::Or(hn::Or(bit(r2 + 2 * cw, 4), bit(r2 + cw, 5)), hn::Or(bit(r2, 6), bit(r1, 7)));
    hn::StoreU(hn::DemoteTo(d8, hn::Or(top, bottom)), d8, out + x);
  }
#endif
  for (; x < out_cols; ++x) {
    const std::int16_t c = r1[x + cw];
    const unsigned code =
        static_cast<unsigned>(r0[x] >= c) | static_cast<unsigned>(r0[x + cw] >= c) << 1 |
        static_cast<unsigned>(r0[x + 2 * cw] >= c) << 2 |
        static_cast<unsigned>(r1[x + 2 * cw] >= c) << 3 |
        static_cast<unsigned>(r2[x + 2 * cw] >= c) << 4 |
        static_cast<unsigned>(r2[x + cw] >= c) << 5 | static_cast<unsigned>(r2[x] >= c) << 6 |
        static_cast<unsigned>(r1[x] >= c) << 7;
    out[x] = static_cast<std::uint8_t>(code);
  }
}

void MapDepthRow(const std::uint16_t* depth, int cols, const FixedPointDepthMap& map,
                 std::uint8_t* out) {
  int u = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<std::int32_t> d32;
  const hn::Rebind<std::uint16_t, decltype(d32)> d16;
  const hn::Rebind<std::uint8_t, decltype(d32)> d8;
  const int lanes = static_cast<int>(hn::Lanes(d32));
  const auto ramp_begin = hn::Set(d32, map.ramp_begin), ramp_last = hn::Set(d32, map.ramp_end - 1);
  const auto ramp_end = hn::Set(d32, map.ramp_end);
  const auto gain = hn::Set(d32, map.gain), offset = hn::Set(d32, map.offset);
  const auto low = hn::Set(d32, map.low), high = hn::Set(d32, map.high);
  const auto unfilled = hn::Set(d32, map.unfilled);
  const auto zero = hn::Zero(d32);
  for (; u + lanes <= cols; u += lanes) {
    const auto v = hn::PromoteTo(d32, hn::LoadU(d16, depth + u));
    const auto on_ramp = hn::Min(hn::Max(v, ramp_begin), ramp_last);
    const auto ramp = hn::ShiftRightSame(hn::Add(hn::Mul(on_ramp, gain), offset), map.shift);
    auto mapped = hn::IfThenElse(hn::Lt(v, ramp_begin), low, ramp);
    mapped = hn::IfThenElse(hn::Lt(v, ramp_end), mapped, high);
    mapped = hn::IfThenElse(hn::Eq(v, zero), unfilled, mapped);
    hn::StoreU(hn::DemoteTo(d8, mapped), d8, out + u);
  }
#endif
  for (; u < cols; ++u) out[u] = map.at(depth[u]);
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::bowls
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::bowls {

HWY_EXPORT(FillHolesInRow);
HWY_EXPORT(LbpCodeRow);
HWY_EXPORT(MapDepthRow);

int fillHolesInRow(const std::uint16_t* above, std::uint16_t* here, const std::uint16_t* below,
                   int cols, bool forward) {
  return HWY_DYNAMIC_DISPATCH(FillHolesInRow)(above, here, below, cols, forward);
}

void lbpCodeRow(const std::int16_t* r0, const std::int16_t* r1, const std::int16_t* r2, int cw,
                std::uint8_t* out, int out_cols) {
  HWY_DYNAMIC_DISPATCH(LbpCodeRow)(r0, r1, r2, cw, out, out_cols);
}

void mapDepthRow(const std::uint16_t* depth, int cols, const FixedPointDepthMap& map,
                 std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(MapDepthRow)(depth, cols, map, out);
}

}  // namespace shapesense::bowls
#endif  // HWY_ONCE
