// The step map's SIMD kernels (see normal_kernels.h), compiled once per Highway target: the
// step marks and the chessboard distance to them, integer work and float compares in the scalar
// definition's order, so every target gives the scalar loops' bits.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "normals/step_map_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// (foreach_target.h first: it re-includes this file once per target.)
#include "hwy/highway.h"
#include "normals/normal_kernels.h"

#include <cmath>
#include <cstddef>

HWY_BEFORE_NAMESPACE();
namespace shapesense::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// StepRule's threshold at zmin for a gap of gap1 - 1 pixels (written as selects in the scalar
// code: zmin = za < zb ? za : zb, threshold = by_factor < by_noise ? by_noise : by_factor).
inline float stepThreshold(const StepRule& rule, float zmin, int gap1) {
  const float by_factor = rule.factor * zmin * static_cast<float>(gap1);
  const float by_noise = rule.noise_k * zmin * zmin;
  return by_factor < by_noise ? by_noise : by_factor;
}

void MarkVerticalSteps(const float* HWY_RESTRICT zrow, int v, int cols, const StepRule& rule,
                       float* HWY_RESTRICT last_z, int* HWY_RESTRICT last_v,
                       std::uint8_t* HWY_RESTRICT marks, std::size_t marks_stride) {
  const hn::CappedTag<float, 8> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto factor = hn::Set(df, rule.factor), noise_k = hn::Set(df, rule.noise_k);
  const auto zero = hn::Zero(df);
  const auto vv = hn::Set(di, v), gap_limit = hn::Set(di, rule.max_gap + 2);
  HWY_ALIGN std::int32_t rows_above[hn::MaxLanes(decltype(di)())];
  HWY_ALIGN std::int32_t hit[hn::MaxLanes(decltype(di)())];
  int u = 0;
  for (; u + n <= cols; u += n) {
    const auto z = hn::LoadU(df, zrow + u), za = hn::LoadU(df, last_z + u);
    const auto lv = hn::LoadU(di, last_v + u);
    const auto ok = z > zero;
    const auto gap1 = vv - lv;  // gap + 1
    const auto zmin = hn::Min(za, z);
    const auto by_factor = factor * zmin * hn::ConvertTo(df, gap1);
    const auto by_noise = noise_k * zmin * zmin;
    const auto step = hn::Abs(z - za) > hn::Max(by_noise, by_factor);
    const auto near = hn::RebindMask(df, gap_limit > gap1);
    const auto mark = hn::And(hn::And(ok, near), step);
    hn::StoreU(hn::IfThenElse(ok, z, za), df, last_z + u);
    hn::StoreU(hn::IfThenElse(hn::RebindMask(di, ok), vv, lv), di, last_v + u);
    if (hn::AllFalse(df, mark)) continue;  // marks are rare
    hn::Store(lv, di, rows_above);
    hn::Store(hn::VecFromMask(di, hn::RebindMask(di, mark)), di, hit);
    for (int k = 0; k < n; ++k)
      if (hit[k]) marks[static_cast<std::size_t>(rows_above[k]) * marks_stride + u + k] = 1;
  }
  for (; u < cols; ++u) {
    const float z = zrow[u], za = last_z[u];
    const int lv = last_v[u];
    const bool ok = z > 0.0f;  // NaN: false
    const float zmin = za < z ? za : z;
    const bool step = std::fabs(z - za) > stepThreshold(rule, zmin, v - lv);
    if (ok && v - lv - 1 <= rule.max_gap && step)
      marks[static_cast<std::size_t>(lv) * marks_stride + u] = 1;
    last_z[u] = ok ? z : za;
    last_v[u] = ok ? v : lv;
  }
}

int MarkHorizontalSteps(const float* HWY_RESTRICT zrow, int cols, const StepRule& rule,
                        std::uint8_t* HWY_RESTRICT marks, int* HWY_RESTRICT after_hole) {
  const hn::CappedTag<float, 8> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint8_t, decltype(di)> du8;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto factor = hn::Set(df, rule.factor), noise_k = hn::Set(df, rule.noise_k);
  const auto zero = hn::Zero(df);
  const auto one = hn::Set(di, 1);
  int holes = 0;
  int u = 1;
  for (; u + n <= cols; u += n) {
    const auto z = hn::LoadU(df, zrow + u), zl = hn::LoadU(df, zrow + u - 1);
    const auto zmin = hn::Min(zl, z);
    const auto by_factor = factor * zmin;
    const auto by_noise = noise_k * zmin * zmin;
    const auto ok = z > zero, ok_left = zl > zero;
    const auto step = hn::And(hn::And(ok, ok_left), hn::Abs(z - zl) > hn::Max(by_noise, by_factor));
    const auto flags = hn::IfThenElseZero(hn::RebindMask(di, step), one);
    hn::StoreU(hn::DemoteTo(du8, flags), du8, marks + u - 1);
    const auto follows_hole = hn::RebindMask(di, hn::AndNot(ok_left, ok));
    if (!hn::AllFalse(di, follows_hole))
      holes += static_cast<int>(
          hn::CompressStore(hn::Iota(di, u), follows_hole, di, after_hole + holes));
  }
  for (; u < cols; ++u) {
    const float z = zrow[u], zl = zrow[u - 1];
    const bool ok = z > 0.0f, ok_left = zl > 0.0f;
    const float zmin = zl < z ? zl : z;
    marks[u - 1] = static_cast<std::uint8_t>(ok && ok_left &&
                                             std::fabs(z - zl) > stepThreshold(rule, zmin, 1));
    if (ok && !ok_left) after_hole[holes++] = u;
  }
  return holes;
}

void InitStepDistanceRow(const std::uint8_t* HWY_RESTRICT marks, int cols, std::int16_t far,
                         std::int16_t* HWY_RESTRICT d) {
  const hn::CappedTag<std::int16_t, 16> di;
  const hn::Rebind<std::uint8_t, decltype(di)> du8;
  const int n = static_cast<int>(hn::Lanes(di));
  const auto vfar = hn::Set(di, far);
  int u = 0;
  for (; u + n <= cols; u += n) {
    const auto m = hn::BitCast(
        di, hn::PromoteTo(hn::RebindToUnsigned<decltype(di)>(), hn::LoadU(du8, marks + u)));
    hn::StoreU(hn::IfThenElseZero(m == hn::Zero(di), vfar), di, d + u);
  }
  for (; u < cols; ++u) d[u] = marks[u] ? std::int16_t{0} : far;
}

void FoldStepDistanceRow(const std::int16_t* HWY_RESTRICT o, int cols,
                         std::int16_t* HWY_RESTRICT d) {
  const hn::CappedTag<std::int16_t, 16> di;
  const int n = static_cast<int>(hn::Lanes(di));
  const auto one = hn::Set(di, 1);
  int u = 1;
  for (; u + n + 1 <= cols; u += n) {
    const auto m =
        hn::Min(hn::Min(hn::LoadU(di, o + u - 1), hn::LoadU(di, o + u)), hn::LoadU(di, o + u + 1)) +
        one;
    hn::StoreU(hn::Min(m, hn::LoadU(di, d + u)), di, d + u);
  }
  for (; u + 1 < cols; ++u) {
    const std::int16_t a = o[u - 1] < o[u] ? o[u - 1] : o[u];
    const auto m = static_cast<std::int16_t>((a < o[u + 1] ? a : o[u + 1]) + 1);
    d[u] = m < d[u] ? m : d[u];
  }
}

// The running minimum d[u] = min over k >= 0 of (d[u - k dir] + k), a vector of pixels per step
// (sixteen where vectors have 256 bits, else eight): shift-add-min steps within the vector
// (k < its lanes), then the vector before enters as its edge value + 1, 2, ... The minima are
// exact, so this gives the serial recurrence's values. Lanes shifted in get `big` ("no value": it
// saturates when incremented). Returns the first pixel not scanned.
#if HWY_TARGET == HWY_SCALAR
int ScanBlocks(std::int16_t*, int cols, int dir) { return dir > 0 ? 0 : cols - 1; }
#else
// Lane i takes lane i - kShift (towards the end) or i + kShift (towards the start); `big` fills
// the lanes shifted in. 128-bit vectors: one byte alignment. 256-bit: the other block's half
// first (lanes across the blocks), then the alignment within each block.
template <int kShift, class D, class V>
HWY_INLINE V towardsEnd(D d, V x, V big) {
  constexpr int kLanes = static_cast<int>(hn::MaxLanes(D()));
  if constexpr (kLanes == 8) {
    return hn::CombineShiftRightBytes<16 - 2 * kShift>(d, x, big);
  } else {
    static_assert(kLanes == 16, "128 or 256 bits");
    const V t = hn::ConcatLowerLower(d, x, big);  // big's lower block, x's lower block
    if constexpr (kShift == 8)
      return t;
    else
      return hn::CombineShiftRightBytes<16 - 2 * kShift>(d, x, t);
  }
}
template <int kShift, class D, class V>
HWY_INLINE V towardsStart(D d, V x, V big) {
  constexpr int kLanes = static_cast<int>(hn::MaxLanes(D()));
  if constexpr (kLanes == 8) {
    return hn::CombineShiftRightBytes<2 * kShift>(d, big, x);
  } else {
    static_assert(kLanes == 16, "128 or 256 bits");
    const V t = hn::ConcatUpperUpper(d, big, x);  // x's upper block, big's upper block
    if constexpr (kShift == 8)
      return t;
    else
      return hn::CombineShiftRightBytes<2 * kShift>(d, t, x);
  }
}
// Every lane: lane kLane of the vector.
template <int kLane, class D, class V>
HWY_INLINE V broadcastLane(D d, V x) {
  constexpr int kLanes = static_cast<int>(hn::MaxLanes(D()));
  if constexpr (kLanes == 8) {
    return hn::Broadcast<kLane>(x);
  } else {
    const V b = hn::Broadcast<kLane % 8>(x);  // within each block
    if constexpr (kLane < 8)
      return hn::ConcatLowerLower(d, b, b);
    else
      return hn::ConcatUpperUpper(d, b, b);
  }
}

int ScanBlocks(std::int16_t* HWY_RESTRICT d, int cols, int dir) {
  const hn::CappedTag<std::int16_t, 16> dv;
  constexpr int n = static_cast<int>(hn::MaxLanes(dv));
  const auto big = hn::Set(dv, 0x7fff);
  auto k = [&](int value) { return hn::Set(dv, static_cast<std::int16_t>(value)); };
  auto carry = big;  // the value before the vector, in every lane
  int u;
  if (dir > 0) {
    const auto ramp = hn::Iota(dv, 1);  // 1..n
    for (u = 0; u + n <= cols; u += n) {
      auto x = hn::LoadU(dv, d + u);
      x = hn::Min(x, hn::SaturatedAdd(towardsEnd<1>(dv, x, big), k(1)));
      x = hn::Min(x, hn::SaturatedAdd(towardsEnd<2>(dv, x, big), k(2)));
      x = hn::Min(x, hn::SaturatedAdd(towardsEnd<4>(dv, x, big), k(4)));
      if constexpr (n == 16) x = hn::Min(x, hn::SaturatedAdd(towardsEnd<8>(dv, x, big), k(8)));
      // The next carry without waiting for the vector's own result: one add and one min a step.
      const auto next = hn::Min(broadcastLane<n - 1>(dv, x), hn::SaturatedAdd(carry, k(n)));
      hn::StoreU(hn::Min(x, hn::SaturatedAdd(carry, ramp)), dv, d + u);
      carry = next;
    }
    return u;
  }
  HWY_ALIGN static constexpr std::int16_t kRampBack[16] = {16, 15, 14, 13, 12, 11, 10, 9,
                                                           8,  7,  6,  5,  4,  3,  2,  1};
  const auto ramp_back = hn::LoadU(dv, kRampBack + 16 - n);  // n..1
  for (u = cols - 1; u - (n - 1) >= 0; u -= n) {
    auto x = hn::LoadU(dv, d + u - (n - 1));
    x = hn::Min(x, hn::SaturatedAdd(towardsStart<1>(dv, x, big), k(1)));
    x = hn::Min(x, hn::SaturatedAdd(towardsStart<2>(dv, x, big), k(2)));
    x = hn::Min(x, hn::SaturatedAdd(towardsStart<4>(dv, x, big), k(4)));
    if constexpr (n == 16) x = hn::Min(x, hn::SaturatedAdd(towardsStart<8>(dv, x, big), k(8)));
    const auto next = hn::Min(broadcastLane<0>(dv, x), hn::SaturatedAdd(carry, k(n)));
    hn::StoreU(hn::Min(x, hn::SaturatedAdd(carry, ramp_back)), dv, d + u - (n - 1));
    carry = next;
  }
  return u;
}
#endif

void ScanStepDistanceRow(std::int16_t* HWY_RESTRICT d, int cols, int dir) {
  int u = ScanBlocks(d, cols, dir);
  const int end = dir > 0 ? cols : -1;
  if (u == (dir > 0 ? 0 : cols - 1)) u += dir;  // the first pixel has nothing before it
  for (; u != end; u += dir) {
    const auto next = static_cast<std::int16_t>(d[u - dir] + 1);
    d[u] = next < d[u] ? next : d[u];
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::detail {

HWY_EXPORT(MarkVerticalSteps);
HWY_EXPORT(MarkHorizontalSteps);
HWY_EXPORT(InitStepDistanceRow);
HWY_EXPORT(FoldStepDistanceRow);
HWY_EXPORT(ScanStepDistanceRow);

void markVerticalSteps(const float* zrow, int v, int cols, const StepRule& rule, float* last_z,
                       int* last_v, std::uint8_t* marks, std::size_t marks_stride) {
  HWY_DYNAMIC_DISPATCH(MarkVerticalSteps)(zrow, v, cols, rule, last_z, last_v, marks, marks_stride);
}
int markHorizontalSteps(const float* zrow, int cols, const StepRule& rule, std::uint8_t* marks,
                        int* after_hole) {
  return HWY_DYNAMIC_DISPATCH(MarkHorizontalSteps)(zrow, cols, rule, marks, after_hole);
}
void initStepDistanceRow(const std::uint8_t* marks, int cols, std::int16_t far, std::int16_t* d) {
  HWY_DYNAMIC_DISPATCH(InitStepDistanceRow)(marks, cols, far, d);
}
void foldStepDistanceRow(const std::int16_t* o, int cols, std::int16_t* d) {
  HWY_DYNAMIC_DISPATCH(FoldStepDistanceRow)(o, cols, d);
}
void scanStepDistanceRow(std::int16_t* d, int cols, int dir) {
  HWY_DYNAMIC_DISPATCH(ScanStepDistanceRow)(d, cols, dir);
}

}  // namespace shapesense::detail
#endif  // HWY_ONCE
