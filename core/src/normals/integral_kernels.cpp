// The normals' per-row input kernels (see normal_kernels.h): z and the points of depth input,
// the gradient modes' window radii and integral rows; compiled once per Highway target. Float
// work keeps the scalar definition's order of operations, as separate multiplies and adds, so
// every target gives the bits of the scalar loops.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "normals/integral_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// (foreach_target.h first: it re-includes this file once per target.)
#include "hwy/highway.h"
#include "normals/block_transpose-inl.h"
#include "normals/normal_kernels.h"

#include <cstddef>
#include <cstring>
#include <limits>

HWY_BEFORE_NAMESPACE();
namespace shapesense::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// ---------------------------------------------------------------- input

void DepthRowToZ(const std::uint16_t* HWY_RESTRICT depth_mm, int cols, float* HWY_RESTRICT z) {
  const hn::CappedTag<float, 8> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint32_t, decltype(df)> du32;
  const hn::Rebind<std::uint16_t, decltype(df)> du16;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto to_metres = hn::Set(df, 0.001f), zero = hn::Zero(df), nan = hn::Set(df, kNaN);
  int u = 0;
  for (; u + n <= cols; u += n) {
    const auto mm = hn::BitCast(di, hn::PromoteTo(du32, hn::LoadU(du16, depth_mm + u)));
    const auto metres = hn::ConvertTo(df, mm) * to_metres;
    hn::StoreU(hn::IfThenElse(metres > zero, metres, nan), df, z + u);
  }
  for (; u < cols; ++u) {
    const float metres = static_cast<float>(depth_mm[u]) * 0.001f;
    z[u] = metres > 0.0f ? metres : kNaN;
  }
}

void PointsRow(const float* HWY_RESTRICT z, const float* HWY_RESTRICT ray_x, float ray_y, int cols,
               float* HWY_RESTRICT xyz) {
  const hn::CappedTag<float, 8> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto ry = hn::Set(df, ray_y);
  int u = 0;
  for (; u + n <= cols; u += n) {
    const auto zv = hn::LoadU(df, z + u);
    hn::StoreInterleaved3(hn::LoadU(df, ray_x + u) * zv, ry * zv, zv, df, xyz + 3 * u);
  }
  for (; u < cols; ++u) {
    xyz[3 * u] = ray_x[u] * z[u];
    xyz[3 * u + 1] = ray_y * z[u];
    xyz[3 * u + 2] = z[u];
  }
}

// ---------------------------------------------------------------- gradient modes

// The radius rule's clamps as min / max (no NaN reaches them: no depth gives z = 0 here).
void WindowRadiusRow(const float* HWY_RESTRICT zrow, const std::int16_t* HWY_RESTRICT dist,
                     const float* HWY_RESTRICT column_bound, int cols, const RadiusRule& rule,
                     int* HWY_RESTRICT radius) {
  const hn::CappedTag<float, 8> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::int16_t, decltype(df)> di16;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto base = hn::Set(df, rule.base_r), constant = hn::Set(df, rule.const_r);
  const auto half = hn::Set(df, 0.5f), min_r = hn::Set(df, rule.min_r);
  const auto max_r = hn::Set(df, rule.max_r), row_bound = hn::Set(df, rule.row_bound);
  const auto two = hn::Set(di, 2);
  int u = 0;
  for (; u + n <= cols; u += n) {
    const auto z = hn::LoadU(df, zrow + u);
    const auto ok = z > hn::Zero(df);
    auto r = base * hn::IfThenElseZero(ok, z) + constant + half;
    r = hn::Min(hn::Max(r, min_r), max_r);
    r = hn::Min(hn::Min(r, hn::LoadU(df, column_bound + u)), row_bound);
    const auto by_step = hn::ConvertTo(df, hn::PromoteTo(di, hn::LoadU(di16, dist + u)) - two);
    r = hn::Min(r, by_step);
    const auto keep = hn::RebindMask(di, hn::And(ok, r >= min_r));
    hn::StoreU(hn::IfThenElseZero(keep, hn::ConvertTo(di, r)), di, radius + u);
  }
  for (; u < cols; ++u) {
    const float z = zrow[u];
    const bool ok = z > 0.0f;
    float r = rule.base_r * (ok ? z : 0.0f) + rule.const_r + 0.5f;
    r = r < rule.min_r ? rule.min_r : r;
    r = r > rule.max_r ? rule.max_r : r;
    r = r < column_bound[u] ? r : column_bound[u];
    r = r < rule.row_bound ? r : rule.row_bound;
    const float by_step = static_cast<float>(dist[u] - 2);
    r = r < by_step ? r : by_step;
    radius[u] = ok && r >= rule.min_r ? static_cast<int>(r) : 0;
  }
}

// 0.1 mm fixed point, 0 where invalid (selected before the conversion).
template <class DF, class DI, class V, class M>
HWY_INLINE hn::Vec<DI> toFixed(DF, DI di, V c, M ok) {
  return hn::ConvertTo(di, hn::IfThenElseZero(ok, c * hn::Set(DF(), 1e4f)));
}
inline std::uint32_t fixedScalar(float c, bool ok) {
  return static_cast<std::uint32_t>(static_cast<std::int32_t>((ok ? c : 0.0f) * 1e4f));
}

// The 3D-gradient integral row of depth input (the points are z times the rays): the elements of
// up to eight pixels transposed and prefix-summed in registers (wrapping uint32 sums: any order
// of the additions gives the same bits); `row` = `above` + the running sum.
void IntegrateGradientRowFromDepth(const float* HWY_RESTRICT z, const float* HWY_RESTRICT ray_x,
                                   float ray_y, int cols, const std::uint32_t* HWY_RESTRICT above,
                                   std::uint32_t* HWY_RESTRICT row) {
  HWY_ALIGN std::uint32_t acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // the running sum (x, y, z, count)
  std::memset(row, 0, 4 * sizeof(std::uint32_t));
  int u = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::CappedTag<float, 8> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::RebindToUnsigned<decltype(df)> du;
  constexpr int n = static_cast<int>(hn::MaxLanes(df));  // four or eight
  const auto ry = hn::Set(df, ray_y);
  auto run = hn::Zero(du);  // the running sum, in every block
  for (; u + n <= cols; u += n) {
    const auto zv = hn::LoadU(df, z + u);
    const auto ok = zv > hn::Zero(df);
    const auto x = hn::BitCast(du, toFixed(df, di, hn::LoadU(df, ray_x + u) * zv, ok));
    const auto y = hn::BitCast(du, toFixed(df, di, ry * zv, ok));
    const auto fz = hn::BitCast(du, toFixed(df, di, zv, ok));
    const auto count = hn::BitCast(du, hn::IfThenElseZero(hn::RebindMask(di, ok), hn::Set(di, 1)));
    hn::Vec<decltype(du)> p0, p1, p2, p3;  // the elements of pixels k (and k + 4: upper block)
    Transpose4x4(du, x, y, fz, count, p0, p1, p2, p3);
    const std::uint32_t* up = above + 4 * (u + 1);
    std::uint32_t* out = row + 4 * (u + 1);
    if constexpr (n == 4) {
      run = run + p0;
      hn::StoreU(hn::LoadU(du, up) + run, du, out);
      run = run + p1;
      hn::StoreU(hn::LoadU(du, up + 4) + run, du, out + 4);
      run = run + p2;
      hn::StoreU(hn::LoadU(du, up + 8) + run, du, out + 8);
      run = run + p3;
      hn::StoreU(hn::LoadU(du, up + 12) + run, du, out + 12);
    } else {
      // Prefix sums within each block, then the lower block's total into the upper one.
      const auto q1 = p0 + p1, q2 = q1 + p2, q3 = q2 + p3;
      const auto carry = run + hn::ConcatLowerLower(du, q3, hn::Zero(du));
      const auto c0 = p0 + carry, c1 = q1 + carry, c2 = q2 + carry, c3 = q3 + carry;
      run = hn::ConcatUpperUpper(du, c3, c3);
      hn::StoreU(hn::LoadU(du, up) + hn::ConcatLowerLower(du, c1, c0), du, out);
      hn::StoreU(hn::LoadU(du, up + 8) + hn::ConcatLowerLower(du, c3, c2), du, out + 8);
      hn::StoreU(hn::LoadU(du, up + 16) + hn::ConcatUpperUpper(du, c1, c0), du, out + 16);
      hn::StoreU(hn::LoadU(du, up + 24) + hn::ConcatUpperUpper(du, c3, c2), du, out + 24);
    }
  }
  hn::Store(run, du, acc);
#endif
  for (; u < cols; ++u) {
    const float zu = z[u];
    const bool ok = zu > 0.0f;
    const std::uint32_t e[4] = {fixedScalar(ray_x[u] * zu, ok), fixedScalar(ray_y * zu, ok),
                                fixedScalar(zu, ok), ok};
    for (int k = 0; k < 4; ++k) {
      acc[k] += e[k];
      row[4 * (u + 1) + k] = above[4 * (u + 1) + k] + acc[k];
    }
  }
}

void GradientElementsFromPoints(const float* HWY_RESTRICT xyz, int cols,
                                std::uint32_t* HWY_RESTRICT elements) {
  const hn::CappedTag<float, 8> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::RebindToUnsigned<decltype(df)> du;
  const int n = static_cast<int>(hn::Lanes(df));
  int u = 0;
  for (; u + n <= cols; u += n) {
    hn::Vec<decltype(df)> x, y, zv;
    hn::LoadInterleaved3(df, xyz + 3 * u, x, y, zv);
    const auto ok = zv > hn::Zero(df);
    const auto count = hn::IfThenElseZero(hn::RebindMask(di, ok), hn::Set(di, 1));
    hn::StoreInterleaved4(
        hn::BitCast(du, toFixed(df, di, x, ok)), hn::BitCast(du, toFixed(df, di, y, ok)),
        hn::BitCast(du, toFixed(df, di, zv, ok)), hn::BitCast(du, count), du, elements + 4 * u);
  }
  for (; u < cols; ++u) {
    const float* p = xyz + 3 * u;
    const bool ok = p[2] > 0.0f;
    std::uint32_t* e = elements + 4 * u;
    for (int k = 0; k < 3; ++k) e[k] = fixedScalar(p[k], ok);
    e[3] = ok;
  }
}

// Integral row = row above + running sum of the row's 4-word elements (wrapping uint32).
void IntegrateGradientRow(const std::uint32_t* HWY_RESTRICT elements, int cols,
                          const std::uint32_t* HWY_RESTRICT above,
                          std::uint32_t* HWY_RESTRICT row) {
  const hn::CappedTag<std::uint32_t, 4> d4;  // one element (a word on the scalar target)
  const int nl = static_cast<int>(hn::Lanes(d4));
  for (int j = 0; j < 4; j += nl) {
    auto acc = hn::Zero(d4);
    hn::StoreU(acc, d4, row + j);
    for (int u = 0; u < cols; ++u) {
      acc = acc + hn::LoadU(d4, elements + 4 * u + j);
      hn::StoreU(hn::LoadU(d4, above + 4 * (u + 1) + j) + acc, d4, row + 4 * (u + 1) + j);
    }
  }
}

// The depth-change integral row: (count, z) pairs as uint64 (count in the low half; it never
// carries into z), `row` = `above` + the running sum; four pixels per step, prefix-summed in
// registers.
void IntegrateDepthChangeRow(const float* HWY_RESTRICT z, int cols,
                             const std::uint32_t* HWY_RESTRICT above,
                             std::uint32_t* HWY_RESTRICT row) {
  std::uint64_t acc = 0;
  std::memset(row, 0, 2 * sizeof(std::uint32_t));
  int u = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::CappedTag<float, 4> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::RebindToUnsigned<decltype(df)> du;
  const hn::Repartition<std::uint64_t, decltype(du)> d64;
  constexpr int n = static_cast<int>(hn::MaxLanes(df));
  static_assert(n == 4, "four pixels per step");
  auto run = hn::Zero(d64);  // the running sum in both lanes
  for (; u + n <= cols; u += n) {
    const auto zv = hn::LoadU(df, z + u);
    const auto ok = zv > hn::Zero(df);
    const auto fz = hn::BitCast(du, toFixed(df, di, zv, ok));
    const auto count = hn::BitCast(du, hn::IfThenElseZero(hn::RebindMask(di, ok), hn::Set(di, 1)));
    auto e01 = hn::BitCast(d64, hn::InterleaveLower(du, count, fz));  // pixels u, u + 1
    auto e23 = hn::BitCast(d64, hn::InterleaveUpper(du, count, fz));
    e01 = e01 + hn::ShiftLeftLanes<1>(d64, e01) + run;
    run = hn::InterleaveUpper(d64, e01, e01);
    e23 = e23 + hn::ShiftLeftLanes<1>(d64, e23) + run;
    run = hn::InterleaveUpper(d64, e23, e23);
    const std::uint32_t* up = above + 2 * (u + 1);
    std::uint32_t* out = row + 2 * (u + 1);
    hn::StoreU(hn::BitCast(du, hn::BitCast(d64, hn::LoadU(du, up)) + e01), du, out);
    hn::StoreU(hn::BitCast(du, hn::BitCast(d64, hn::LoadU(du, up + 4)) + e23), du, out + 4);
  }
  acc = hn::GetLane(run);
#endif
  for (; u < cols; ++u) {
    const bool ok = z[u] > 0.0f;
    acc +=
        static_cast<std::uint64_t>(ok) + (static_cast<std::uint64_t>(fixedScalar(z[u], ok)) << 32);
    std::uint64_t x;
    std::memcpy(&x, above + 2 * (u + 1), sizeof x);
    x += acc;
    std::memcpy(row + 2 * (u + 1), &x, sizeof x);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::detail {

HWY_EXPORT(DepthRowToZ);
HWY_EXPORT(PointsRow);
HWY_EXPORT(WindowRadiusRow);
HWY_EXPORT(IntegrateGradientRowFromDepth);
HWY_EXPORT(GradientElementsFromPoints);
HWY_EXPORT(IntegrateDepthChangeRow);
HWY_EXPORT(IntegrateGradientRow);

void depthRowToZ(const std::uint16_t* depth_mm, int cols, float* z) {
  HWY_DYNAMIC_DISPATCH(DepthRowToZ)(depth_mm, cols, z);
}
void pointsRow(const float* z, const float* ray_x, float ray_y, int cols, float* xyz) {
  HWY_DYNAMIC_DISPATCH(PointsRow)(z, ray_x, ray_y, cols, xyz);
}
void windowRadiusRow(const float* zrow, const std::int16_t* step_distance,
                     const float* column_bound, int cols, const RadiusRule& rule, int* radius) {
  HWY_DYNAMIC_DISPATCH(WindowRadiusRow)(zrow, step_distance, column_bound, cols, rule, radius);
}
void integrateGradientRowFromDepth(const float* z, const float* ray_x, float ray_y, int cols,
                                   const std::uint32_t* above, std::uint32_t* row) {
  HWY_DYNAMIC_DISPATCH(IntegrateGradientRowFromDepth)(z, ray_x, ray_y, cols, above, row);
}
void gradientElementsFromPoints(const float* xyz, int cols, std::uint32_t* elements) {
  HWY_DYNAMIC_DISPATCH(GradientElementsFromPoints)(xyz, cols, elements);
}
void integrateGradientRow(const std::uint32_t* elements, int cols, const std::uint32_t* above,
                          std::uint32_t* row) {
  HWY_DYNAMIC_DISPATCH(IntegrateGradientRow)(elements, cols, above, row);
}
void integrateDepthChangeRow(const float* z, int cols, const std::uint32_t* above,
                             std::uint32_t* row) {
  HWY_DYNAMIC_DISPATCH(IntegrateDepthChangeRow)(z, cols, above, row);
}

}  // namespace shapesense::detail
#endif  // HWY_ONCE
