// The point grid's radius kernel, written once with Google Highway (see neighbour_kernels.h).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recognition/neighbour_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// Highway's foreach_target must come before highway.h.
#include <hwy/highway.h>

#include "recognition/neighbour_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

std::size_t IndicesWithin(const CandidateColumns& c, float cx, float cy, float cz, float radius2,
                          std::uint32_t* out) {
  const hn::ScalableTag<float> df;
  const hn::RebindToUnsigned<decltype(df)> du;
  const std::size_t lanes = hn::Lanes(df);
  const auto centre_x = hn::Set(df, cx);
  const auto centre_y = hn::Set(df, cy);
  const auto centre_z = hn::Set(df, cz);
  const auto bound = hn::Set(df, radius2);
  std::size_t kept = 0;
  std::size_t k = 0;
  for (; k + lanes <= c.count; k += lanes) {
    const auto dx = hn::Sub(hn::LoadU(df, c.x + k), centre_x);
    const auto dy = hn::Sub(hn::LoadU(df, c.y + k), centre_y);
    const auto dz = hn::Sub(hn::LoadU(df, c.z + k), centre_z);
    const auto d2 = hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz));
    const auto inside = hn::RebindMask(du, hn::Le(d2, bound));
    // Compress in registers, then a full store (AVX-512's compress-to-memory is microcoded and
    // slow on AMD Zen 4): `out` has room past the candidates' count.
    hn::StoreU(hn::Compress(hn::LoadU(du, c.index + k), inside), du, out + kept);
    kept += hn::CountTrue(du, inside);
  }
  for (; k < c.count; ++k) {
    const float dx = c.x[k] - cx, dy = c.y[k] - cy, dz = c.z[k] - cz;
    out[kept] = c.index[k];
    kept += dx * dx + dy * dy + dz * dz <= radius2 ? 1 : 0;
  }
  return kept;
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::detail {

HWY_EXPORT(IndicesWithin);

std::size_t indicesWithin(const CandidateColumns& candidates, float cx, float cy, float cz,
                          float radius2, std::uint32_t* out) {
  return HWY_DYNAMIC_DISPATCH(IndicesWithin)(candidates, cx, cy, cz, radius2, out);
}

}  // namespace shapesense::detail
#endif  // HWY_ONCE
