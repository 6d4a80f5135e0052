// The descriptor distance kernel, written once with Google Highway (see descriptor_kernels.h).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recognition/descriptor_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// Highway's foreach_target must come before highway.h.
#include <hwy/highway.h>

#include <algorithm>

#include "recognition/descriptor_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

constexpr std::size_t kQueriesAtOnce = 4;

// Up to four queries against every column block.
void FourQueries(const float* const* queries, std::size_t query_count, const float* columns,
                 std::size_t count, float* out) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  std::size_t i = 0;
  for (; i + lanes <= count; i += lanes) {
    auto sum0 = hn::Zero(d), sum1 = hn::Zero(d), sum2 = hn::Zero(d), sum3 = hn::Zero(d);
    for (std::size_t k = 0; k < kShapeDescriptorSize; ++k) {
      const auto column = hn::LoadU(d, columns + k * count + i);
      const auto diff0 = hn::Sub(hn::Set(d, queries[0][k]), column);
      sum0 = hn::Add(sum0, hn::Mul(diff0, diff0));
      if (query_count > 1) {
        const auto diff1 = hn::Sub(hn::Set(d, queries[1][k]), column);
        sum1 = hn::Add(sum1, hn::Mul(diff1, diff1));
      }
      if (query_count > 2) {
        const auto diff2 = hn::Sub(hn::Set(d, queries[2][k]), column);
        sum2 = hn::Add(sum2, hn::Mul(diff2, diff2));
      }
      if (query_count > 3) {
        const auto diff3 = hn::Sub(hn::Set(d, queries[3][k]), column);
        sum3 = hn::Add(sum3, hn::Mul(diff3, diff3));
      }
    }
    hn::StoreU(sum0, d, out + i);
    if (query_count > 1) hn::StoreU(sum1, d, out + count + i);
    if (query_count > 2) hn::StoreU(sum2, d, out + 2 * count + i);
    if (query_count > 3) hn::StoreU(sum3, d, out + 3 * count + i);
  }
  for (; i < count; ++i)
    for (std::size_t q = 0; q < query_count; ++q) {
      float sum = 0.0f;
      for (std::size_t k = 0; k < kShapeDescriptorSize; ++k) {
        const float diff = queries[q][k] - columns[k * count + i];
        sum += diff * diff;
      }
      out[q * count + i] = sum;
    }
}

void SquaredDistancesToAll(const float* const* queries, std::size_t query_count,
                           const float* columns, std::size_t count, float* out) {
  for (std::size_t q = 0; q < query_count; q += kQueriesAtOnce)
    FourQueries(queries + q, std::min(kQueriesAtOnce, query_count - q), columns, count,
                out + q * count);
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::detail {

HWY_EXPORT(SquaredDistancesToAll);

void squaredDistancesToAll(const float* const* queries, std::size_t query_count,
                           const float* columns, std::size_t count, float* out) {
  HWY_DYNAMIC_DISPATCH(SquaredDistancesToAll)(queries, query_count, columns, count, out);
}

}  // namespace shapesense::detail
#endif  // HWY_ONCE
