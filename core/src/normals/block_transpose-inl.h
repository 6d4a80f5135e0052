// The 4x4 transposes of 32-bit words within each 128-bit block, for the normals' kernels; a
// Highway per-target header: included by each kernel file once per target (after
// foreach_target.h). Not on the scalar target (one lane per vector, no block shuffles).

#if defined(SHAPESENSE_NORMALS_BLOCK_TRANSPOSE_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef SHAPESENSE_NORMALS_BLOCK_TRANSPOSE_INL_H_
#undef SHAPESENSE_NORMALS_BLOCK_TRANSPOSE_INL_H_
#else
#define SHAPESENSE_NORMALS_BLOCK_TRANSPOSE_INL_H_
#endif

#include <cstdint>

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

#if HWY_TARGET != HWY_SCALAR
// The 4x4 transposes of 32-bit words within each 128-bit block: word k of o_j is word j of
// the k-th input.
template <class DU, class V>
HWY_INLINE void Transpose4x4(DU du, V a, V b, V c, V d, V& o0, V& o1, V& o2, V& o3) {
  const hn::Repartition<std::uint64_t, DU> d64;
  const auto ab01 = hn::BitCast(d64, hn::InterleaveLower(du, a, b));  // a0 b0 a1 b1
  const auto cd01 = hn::BitCast(d64, hn::InterleaveLower(du, c, d));
  const auto ab23 = hn::BitCast(d64, hn::InterleaveUpper(du, a, b));  // a2 b2 a3 b3
  const auto cd23 = hn::BitCast(d64, hn::InterleaveUpper(du, c, d));
  o0 = hn::BitCast(du, hn::InterleaveLower(d64, ab01, cd01));  // a0 b0 c0 d0
  o1 = hn::BitCast(du, hn::InterleaveUpper(d64, ab01, cd01));
  o2 = hn::BitCast(du, hn::InterleaveLower(d64, ab23, cd23));
  o3 = hn::BitCast(du, hn::InterleaveUpper(d64, ab23, cd23));
}
#endif

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::detail
HWY_AFTER_NAMESPACE();

#endif  // SHAPESENSE_NORMALS_BLOCK_TRANSPOSE_INL_H_ per target
