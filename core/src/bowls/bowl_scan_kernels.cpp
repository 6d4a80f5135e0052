// The bowl scan kernel, written once with Google Highway (see bowl_scan_kernels.h).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "bowls/bowl_scan_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// Highway's foreach_target must come before highway.h.
#include <hwy/highway.h>

#include "bowls/bowl_scan_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::bowls {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

FirstStagesResult FirstStagesStride2(const FirstStagesRow& row, int* alive_x,
                                     std::int32_t* alive_score) {
  FirstStagesResult r;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<std::int32_t> d32;
  const hn::Rebind<std::uint16_t, decltype(d32)> d16;
  const hn::Repartition<std::uint8_t, decltype(d16)> d8_pairs;  // the bytes of d16's lanes
  const hn::Rebind<std::uint8_t, decltype(d32)> d8;
  const std::size_t lanes = hn::Lanes(d32);
  const auto threshold0 = hn::Set(d32, row.threshold0);
  const auto threshold1 = hn::Set(d32, row.threshold1);
  const auto low_byte = hn::Set(d16, std::uint16_t{0xFF});
  // The code of window i is byte 2i of the code row: the low byte of 16-bit lane i.
  auto codesAt = [&](const std::uint8_t* codes, std::size_t i) {
    const auto pairs = hn::BitCast(d16, hn::LoadU(d8_pairs, codes + 2 * i));
    return hn::PromoteTo(d32, hn::And(pairs, low_byte));
  };
  std::size_t i = 0;
  for (; i + lanes <= row.windows; i += lanes) {
    const auto h0 = hn::GatherIndex(d32, row.lut0, codesAt(row.codes0, i));
    const auto h1 = hn::Add(h0, hn::GatherIndex(d32, row.lut1, codesAt(row.codes1, i)));
    const auto gated = hn::PromoteTo(d32, hn::LoadU(d8, row.in_gate + i));
    const auto keep =
        hn::And(hn::And(hn::Not(hn::Lt(h0, threshold0)), hn::Not(hn::Lt(h1, threshold1))),
                hn::Ne(gated, hn::Zero(d32)));
    const auto x = hn::ShiftLeft<1>(hn::Iota(d32, static_cast<std::int32_t>(i)));
    // Compress in registers, then a full store: kept <= i, so the store stays inside the
    // row's buffers, and AVX-512's compress-to-memory is microcoded and slow on AMD Zen 4.
    hn::StoreU(hn::Compress(x, keep), d32, alive_x + r.kept);
    hn::StoreU(hn::Compress(h1, keep), d32, alive_score + r.kept);
    r.kept += hn::CountTrue(d32, keep);
  }
  r.processed = i;
#else
  (void)row, (void)alive_x, (void)alive_score;
#endif
  return r;
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::bowls
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::bowls {

HWY_EXPORT(FirstStagesStride2);

FirstStagesResult firstStagesStride2(const FirstStagesRow& row, int* alive_x,
                                     std::int32_t* alive_score) {
  return HWY_DYNAMIC_DISPATCH(FirstStagesStride2)(row, alive_x, alive_score);
}

}  // namespace shapesense::bowls
#endif  // HWY_ONCE
