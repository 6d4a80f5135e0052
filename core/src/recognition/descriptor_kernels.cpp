// The descriptor distance kernel, written once with Google Highway (see descriptor_kernels.h).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recognition/descriptor_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// Highway's foreach_target must come before highway.h.
#include <hwy/highway.h>

#include "recognition/descriptor_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void SquaredDistancesToAll(const float* const* queries, std::size_t query_count,
                           const float* columns, std::size_t count, float* out) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  for (std::size_t q = 0; q < query_count; ++q) {
    const float* query = queries[q];
    float* row = out + q * count;
    std::size_t i = 0;
    for (; i + lanes <= count; i += lanes) {
      auto sum = hn::Zero(d);
      for (std::size_t k = 0; k < kShapeDescriptorSize; ++k) {
        const auto diff = hn::Sub(hn::Set(d, query[k]), hn::LoadU(d, columns + k * count + i));
        sum = hn::Add(sum, hn::Mul(diff, diff));
      }
      hn::StoreU(sum, d, row + i);
    }
    for (; i < count; ++i) {
      float sum = 0.0f;
      for (std::size_t k = 0; k < kShapeDescriptorSize; ++k) {
        const float diff = query[k] - columns[k * count + i];
        sum += diff * diff;
      }
      row[i] = sum;
    }
  }
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
