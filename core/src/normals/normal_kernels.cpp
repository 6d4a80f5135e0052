// The normals' SIMD kernels (see normal_kernels.h), compiled once per Highway target.
// Float work keeps the scalar definition's order of operations, as separate multiplies and adds
// (Highway's MulAdd would fuse them and round differently), so every target gives the bits of
// the scalar loops; min / max only ever see NaN in lanes whose result is masked out.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "normals/normal_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// (foreach_target.h first: it re-includes this file once per target.)
#include "hwy/highway.h"
#include "normals/gradient_windows.h"
#include "normals/normal_kernels.h"

#include <cmath>
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

#if HWY_TARGET != HWY_SCALAR  // (no block shuffles there; one lane per vector)
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

// The window sums of N consecutive centres as they lie in memory (L vectors of N words, the
// elements interleaved) as channels: chan[k] = word k of every element, count = the count word,
// in centre order. The transposes of LoadInterleaved4 / LoadInterleaved2, in registers (the
// sums are not stored and loaded back).
template <GradientMode M, class DU, class V>
HWY_INLINE void DeinterleaveSums(DU du, const V* s, V* chan, V& count) {
#if HWY_TARGET == HWY_SCALAR  // one word per vector
  (void)du;
  if constexpr (M == GradientMode::k3dGradient) {
    for (int k = 0; k < 3; ++k) chan[k] = s[k];
    count = s[3];
  } else {
    count = s[0];
    chan[0] = s[1];
  }
#else
  constexpr std::size_t N = hn::MaxLanes(DU());
  static_assert(N == 4 || N == 8, "groups of four or eight centres");
  if constexpr (M == GradientMode::k3dGradient) {
    V s0 = s[0], s1 = s[1], s2 = s[2], s3 = s[3];
    if constexpr (N == 8) {  // centres k (lower block) and k + 4 (upper block)
      s0 = hn::ConcatLowerLower(du, s[2], s[0]);
      s1 = hn::ConcatUpperUpper(du, s[2], s[0]);
      s2 = hn::ConcatLowerLower(du, s[3], s[1]);
      s3 = hn::ConcatUpperUpper(du, s[3], s[1]);
    }
    Transpose4x4(du, s0, s1, s2, s3, chan[0], chan[1], chan[2], count);
  } else {  // (count, z) pairs
    count = hn::ConcatEven(du, s[1], s[0]);
    chan[0] = hn::ConcatOdd(du, s[1], s[0]);
  }
#endif
}

// Groups of up to eight pixels (four on 128-bit targets): where the valid pixels of a group
// share one window radius r, their windows are computed together and their normals with the
// operations of unnormalisedNormal() and normalizePixels() - the same bits. Invalid pixels
// (r = 0) ride along with radius r and come out NaN.
template <class GroupTag>
struct GroupKernels {
  using GroupVec = hn::Vec<GroupTag>;
  using WordTag = hn::RebindToUnsigned<GroupTag>;
  using WordVec = hn::Vec<WordTag>;
  static constexpr int kMaxLanes = static_cast<int>(hn::MaxLanes(GroupTag()));

  // The window means of centres x..x+N-1 from their window sums (channels), into the cache.
  template <GradientMode M>
  static HWY_INLINE void StoreMeans(const GradientRow& g, const WordVec* chan, WordVec count,
                                    float* means, int x) {
    const GroupTag df;
    const hn::RebindToSigned<GroupTag> di;
    const auto nf = hn::ConvertTo(df, hn::BitCast(di, count));
    // 1 / n correctly rounded (the inv_count table's values), 0 for n = 0.
    const auto inv_n = hn::IfThenElseZero(nf > hn::Zero(df), hn::Set(df, 1.0f) / nf);
    constexpr int K = windowChannels(M);
    for (int k = 0; k < K - 1; ++k)
      hn::StoreU(hn::ConvertTo(df, hn::BitCast(di, chan[k])) * inv_n, df, means + k * g.cols + x);
    hn::StoreU(nf, df, means + (K - 1) * g.cols + x);
  }

  // cacheWindow() for centres x..x+N-1, radius r.
  template <GradientMode M>
  static HWY_INLINE void CacheGroup(const GradientRow& g, float* means, int* radii, int x, int y,
                                    int r) {
    constexpr int L = elementWords(M);
    const hn::RebindToSigned<GroupTag> di;
    const WordTag du;
    const int n = static_cast<int>(hn::Lanes(du));
    hn::StoreU(hn::Set(di, r), di, radii + x);
    const std::ptrdiff_t dh = (2 * r + 1) * L;
    const std::uint32_t* a = g.integral[y - r] + (x - r) * L;
    const std::uint32_t* c = g.integral[y + r + 1] + (x - r) * L;
    // The window sums of the N centres (wrapped four-corner differences), elements interleaved.
    WordVec s[L];
    for (int i = 0; i < L; ++i) {
      s[i] = hn::LoadU(du, c + dh + i * n) - hn::LoadU(du, a + dh + i * n) -
             hn::LoadU(du, c + i * n) + hn::LoadU(du, a + i * n);
    }
    WordVec chan[3], count;
    DeinterleaveSums<M>(du, s, chan, count);
    StoreMeans<M>(g, chan, count, means, x);
  }

  // cacheWindow() for centres x..x+N-1, centre x + k with radius radius[k].
  template <GradientMode M>
  static HWY_NOINLINE void CacheLanes(const GradientRow& g, float* means, int* radii, int x, int y,
                                      const int* radius) {
    constexpr int L = elementWords(M);
    const hn::RebindToSigned<GroupTag> di;
    const WordTag du;
    hn::StoreU(hn::LoadU(di, radius), di, radii + x);
    WordVec chan[3], count;
#if HWY_TARGET != HWY_SCALAR
    if constexpr (kMaxLanes == 4) {
      // Lane k's window sum in the low L words of s[k] (a four-word load: the depth change's
      // reads two words past the element, within the ring's slack).
      WordVec s[4];
      for (int k = 0; k < 4; ++k) {
        const int r = radius[k];
        const std::ptrdiff_t dh = (2 * r + 1) * L;
        const std::uint32_t* a = g.integral[y - r] + (x + k - r) * L;
        const std::uint32_t* c = g.integral[y + r + 1] + (x + k - r) * L;
        s[k] = hn::LoadU(du, c + dh) - hn::LoadU(du, a + dh) - hn::LoadU(du, c) + hn::LoadU(du, a);
      }
      if constexpr (M == GradientMode::kDepthChange) {  // the pairs as they lie in memory
        const hn::Repartition<std::uint64_t, WordTag> d64;
        s[0] = hn::BitCast(
            du, hn::InterleaveLower(d64, hn::BitCast(d64, s[0]), hn::BitCast(d64, s[1])));
        s[1] = hn::BitCast(
            du, hn::InterleaveLower(d64, hn::BitCast(d64, s[2]), hn::BitCast(d64, s[3])));
      }
      DeinterleaveSums<M>(du, s, chan, count);
    } else
#endif
    {
      const int n = static_cast<int>(hn::Lanes(du));
      HWY_ALIGN std::uint32_t sums[4 * kMaxLanes];
      const hn::CappedTag<std::uint32_t, L> de;  // one element (fewer lanes on the scalar target)
      const int ne = static_cast<int>(hn::Lanes(de));
      for (int k = 0; k < n; ++k) {
        const int r = radius[k];
        const std::ptrdiff_t dh = (2 * r + 1) * L;
        const std::uint32_t* a = g.integral[y - r] + (x + k - r) * L;
        const std::uint32_t* c = g.integral[y + r + 1] + (x + k - r) * L;
        for (int j = 0; j < L; j += ne) {
          const auto e = hn::LoadU(de, c + dh + j) - hn::LoadU(de, a + dh + j) -
                         hn::LoadU(de, c + j) + hn::LoadU(de, a + j);
          hn::StoreU(e, de, sums + k * L + j);
        }
      }
      WordVec s[L];
      for (int i = 0; i < L; ++i) s[i] = hn::Load(du, sums + i * n);
      DeinterleaveSums<M>(du, s, chan, count);
    }
    StoreMeans<M>(g, chan, count, means, x);
  }

  // Makes the cache hold the windows of `radius` (one per lane) at centres x..x+N-1.
  template <GradientMode M>
  static HWY_INLINE void EnsureLanes(const GradientRow& g, float* means, int* radii, int x, int y,
                                     const int* radius) {
    const hn::RebindToSigned<GroupTag> di;
    if (!hn::AllTrue(di, hn::LoadU(di, radii + x) == hn::LoadU(di, radius)))
      CacheLanes<M>(g, means, radii, x, y, radius);
  }
  template <GradientMode M>
  static HWY_INLINE void EnsureGroup(const GradientRow& g, float* means, int* radii, int x, int y,
                                     int r) {
    const hn::RebindToSigned<GroupTag> di;
    if (!hn::AllTrue(di, hn::LoadU(di, radii + x) == hn::Set(di, r)))
      CacheGroup<M>(g, means, radii, x, y, r);
  }

  // The means (channels 0..K-1) of the four windows of pixels u..u+N-1.
  struct GroupWindows {
    GroupVec left[4], right[4], up[4], down[4];
  };

  template <GradientMode M>
  static HWY_INLINE void LoadWindows(const GradientRow& g, int u, bool left_right, bool up_down,
                                     GroupWindows& w) {
    constexpr int K = windowChannels(M);
    const GroupTag df;
    const int cols = g.cols;
    for (int k = 0; k < K; ++k) {
      if (left_right) {
        w.left[k] = hn::LoadU(df, g.mean_here + k * cols + u - 1);
        w.right[k] = hn::LoadU(df, g.mean_here + k * cols + u + 1);
      }
      if (up_down) {
        w.up[k] = hn::LoadU(df, g.mean_above + k * cols + u);
        w.down[k] = hn::LoadU(df, g.mean_below + k * cols + u);
      }
    }
  }

  // The unnormalised normals of pixels u..u+N-1 from their windows' means; 0 outside `ok` or where
  // a window has fewer valid pixels than min_n.
  template <GradientMode M>
  static HWY_INLINE void NormalsFromWindows(const GradientRow& g, int u, const GroupWindows& w,
                                            hn::Mask<GroupTag> ok, GroupVec min_n, GroupVec& nx,
                                            GroupVec& ny, GroupVec& nz) {
    constexpr int K = windowChannels(M);
    const GroupTag df;
    const auto fewest =
        hn::Min(hn::Min(w.left[K - 1], w.right[K - 1]), hn::Min(w.up[K - 1], w.down[K - 1]));
    ok = hn::And(ok, fewest >= min_n);
    if constexpr (M == GradientMode::k3dGradient) {
      const auto hx = w.right[0] - w.left[0], hy = w.right[1] - w.left[1];
      const auto hz = w.right[2] - w.left[2];
      const auto tx = w.down[0] - w.up[0], ty = w.down[1] - w.up[1], tz = w.down[2] - w.up[2];
      nx = hy * tz - hz * ty;
      ny = hz * tx - hx * tz;
      nz = hx * ty - hy * tx;
    } else {
      const auto zl = w.left[0], zr = w.right[0], zu = w.up[0], zd = w.down[0];
      const auto half = hn::Set(df, 0.5f);
      const auto du = half * (zr - zl), dv = half * (zd - zu);
      const auto zm = hn::Set(df, 0.25f) * (zl + zr + zu + zd);
      const auto dx = hn::Set(df, static_cast<float>(u)) + hn::Iota(df, 0) - hn::Set(df, g.cx);
      const auto dy = hn::Set(df, static_cast<float>(g.v) - g.cy);
      nx = hn::Set(df, g.fx) * du;
      ny = hn::Set(df, g.fy) * dv;
      nz = hn::Neg(zm + dx * du + dy * dv);
    }
    nx = hn::IfThenElseZero(ok, nx);
    ny = hn::IfThenElseZero(ok, ny);
    nz = hn::IfThenElseZero(ok, nz);
  }

  // Pixels u..u+N-1 whose radius is r (`lanes`); 0 in the others.
  template <GradientMode M>
  static HWY_INLINE void GroupNormals(const GradientRow& g, int u, int r, hn::Mask<GroupTag> lanes,
                                      GroupVec& nx, GroupVec& ny, GroupVec& nz) {
    const int v = g.v;
    EnsureGroup<M>(g, g.mean_here, g.radius_here, u - 1, v, r);
    EnsureGroup<M>(g, g.mean_here, g.radius_here, u + 1, v, r);
    EnsureGroup<M>(g, g.mean_above, g.radius_above, u, v - 1, r);
    EnsureGroup<M>(g, g.mean_below, g.radius_below, u, v + 1, r);
    GroupWindows w;
    LoadWindows<M>(g, u, true, true, w);
    NormalsFromWindows<M>(g, u, w, lanes, hn::Set(GroupTag(), static_cast<float>(g.min_count[r])),
                          nx, ny, nz);
  }

  // Pixels u..u+N-1 with a radius per lane (`radius`; `valid`: the lanes with a normal). The left
  // windows are read before the right ones are ensured: the right window of lane k can evict the
  // left window of lane k + 2 (same centre, another radius). Out of line: rare.
  template <GradientMode M>
  static HWY_NOINLINE void LanesNormals(const GradientRow& g, int u, const int* radius,
                                        hn::Mask<GroupTag> valid, GroupVec& nx, GroupVec& ny,
                                        GroupVec& nz) {
    const GroupTag df;
    const int n = static_cast<int>(hn::Lanes(df)), v = g.v;
    GroupWindows w, right;
    EnsureLanes<M>(g, g.mean_here, g.radius_here, u - 1, v, radius);
    LoadWindows<M>(g, u, true, false, w);
    EnsureLanes<M>(g, g.mean_here, g.radius_here, u + 1, v, radius);
    LoadWindows<M>(g, u, true, false, right);
    for (int k = 0; k < windowChannels(M); ++k) w.right[k] = right.right[k];
    EnsureLanes<M>(g, g.mean_above, g.radius_above, u, v - 1, radius);
    EnsureLanes<M>(g, g.mean_below, g.radius_below, u, v + 1, radius);
    LoadWindows<M>(g, u, false, true, w);
    HWY_ALIGN float min_n[hn::MaxLanes(GroupTag())];
    for (int k = 0; k < n; ++k) min_n[k] = static_cast<float>(g.min_count[radius[k]]);
    NormalsFromWindows<M>(g, u, w, valid, hn::Load(df, min_n), nx, ny, nz);
  }

  // Unit normals of pixels u..u+N-1 facing the camera (n . ray < 0), NaN where the unnormalised
  // normal is (near) zero, interleaved into the output row.
  static HWY_INLINE void NormalizeGroup(const GradientRow& g, int u, GroupVec nx, GroupVec ny,
                                        GroupVec nz) {
    const GroupTag df;
    const auto eps = hn::Set(df, 1e-20f);
    const auto len2 = nx * nx + ny * ny + nz * nz;
    const auto rx = (hn::Set(df, static_cast<float>(u)) + hn::Iota(df, 0) - hn::Set(df, g.cx)) *
                    hn::Set(df, g.ifx);
    const auto dot = nx * rx + ny * hn::Set(df, g.ray_y) + nz;
    auto k = hn::Set(df, 1.0f) / hn::Sqrt(hn::Max(len2, eps));
    k = hn::IfThenElse(dot > hn::Zero(df), hn::Neg(k), k);
    k = hn::IfThenElse(len2 > eps, k, hn::Set(df, kNaN));
    hn::StoreInterleaved3(nx * k, ny * k, nz * k, df, g.out + 3 * u);
  }

  enum class Outcome { kDone, kBorder, kMixed };

  // Pixels u..u+N-1: NaN without valid pixels; together where the windows of centres
  // u - 1 .. u + N lie inside the image (a valid pixel's radius is bounded by the border; invalid
  // ones ride along with r, which fits the rows). Other groups (valid pixels of different radii,
  // or the image border) are done lane by lane only with `lane_radii`, else left to the caller
  // (kMixed, kBorder). Lane by lane, invalid pixels ride along with r or, at the border, the
  // largest radius the image width leaves them; where that is none (the outermost two columns),
  // the group is left to the caller (kBorder).
  template <GradientMode M>
  static HWY_INLINE Outcome Group(const GradientRow& g, int u, bool lane_radii) {
    const GroupTag df;
    const hn::RebindToSigned<GroupTag> di;
    const int n = static_cast<int>(hn::Lanes(df));
    const auto radii = hn::LoadU(di, g.radius + u);
    const auto invalid = radii == hn::Zero(di);
    if (hn::AllTrue(di, invalid)) {
      const auto nan = hn::Set(df, kNaN);
      hn::StoreInterleaved3(nan, nan, nan, df, g.out + 3 * u);
      return Outcome::kDone;
    }
    const int r = g.radius[u + hn::FindFirstTrue(di, hn::Not(invalid))];
    const bool border = u - 1 - r < 0 || u + n + 1 + r > g.cols;
    const auto lanes = radii == hn::Set(di, r);
    GroupVec nx, ny, nz;
    if (!border && hn::AllTrue(di, hn::Or(invalid, lanes))) {
      GroupNormals<M>(g, u, r, hn::RebindMask(df, lanes), nx, ny, nz);
    } else {
      if (!lane_radii) return border ? Outcome::kBorder : Outcome::kMixed;
      const auto column = hn::Iota(di, 0) + hn::Set(di, u);
      const auto column_bound = hn::Min(column, hn::Set(di, g.cols - 1) - column) - hn::Set(di, 1);
      const auto ride = hn::Min(hn::Set(di, r), column_bound);  // r away from the border
      if (!hn::AllTrue(di, hn::Or(hn::Not(invalid), ride > hn::Zero(di)))) return Outcome::kBorder;
      HWY_ALIGN int lane_radius[hn::MaxLanes(decltype(di)())];
      hn::Store(hn::IfThenElse(invalid, ride, radii), di, lane_radius);
      LanesNormals<M>(g, u, lane_radius, hn::RebindMask(df, hn::Not(invalid)), nx, ny, nz);
    }
    NormalizeGroup(g, u, nx, ny, nz);
    return Outcome::kDone;
  }

  // Pixels u..u+N-1 one at a time (the image border), normalised together.
  template <GradientMode M>
  static HWY_NOINLINE void PixelByPixel(const GradientRow& g, int u) {
    const GroupTag df;
    const int n = static_cast<int>(hn::Lanes(df));
    for (int k = 0; k < n; ++k) unnormalisedNormal<M>(g, u + k);
    NormalizeGroup(g, u, hn::LoadU(df, g.normal_x + u), hn::LoadU(df, g.normal_y + u),
                   hn::LoadU(df, g.normal_z + u));
  }
};

// Groups of eight pixels where their valid pixels share a radius, else groups of four (the
// windows of a radius per lane cost a sum per lane: fewer lanes, fewer misses); the vector
// width where that is less (four on 128-bit targets, one on the scalar one).
using WideGroups = GroupKernels<hn::CappedTag<float, 8>>;
using NarrowGroups = GroupKernels<hn::CappedTag<float, 4>>;

template <GradientMode M>
void NormalsRow(const GradientRow& g) {
  const int wide = static_cast<int>(hn::Lanes(hn::CappedTag<float, 8>()));
  const int narrow = static_cast<int>(hn::Lanes(hn::CappedTag<float, 4>()));
  const int cols = g.cols;
  int u = 0;
  if (narrow < wide) {
    // A group of eight that is not done (mixed radii or the border) is done as a group of four,
    // and the groups of eight go on four pixels later.
    while (u + narrow <= cols) {
      if (u + wide <= cols && WideGroups::Group<M>(g, u, false) == WideGroups::Outcome::kDone) {
        u += wide;
        continue;
      }
      if (NarrowGroups::Group<M>(g, u, true) == NarrowGroups::Outcome::kBorder)
        NarrowGroups::PixelByPixel<M>(g, u);
      u += narrow;
    }
  } else {
    for (; u + wide <= cols; u += wide)
      if (WideGroups::Group<M>(g, u, true) == WideGroups::Outcome::kBorder)
        WideGroups::PixelByPixel<M>(g, u);
  }
  for (int k = u; k < cols; ++k) unnormalisedNormal<M>(g, k);
  normalizePixels(g, u, cols);
}

void GradientNormalsRow(const GradientRow& g) { NormalsRow<GradientMode::k3dGradient>(g); }
void DepthChangeNormalsRow(const GradientRow& g) { NormalsRow<GradientMode::kDepthChange>(g); }

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
HWY_EXPORT(GradientNormalsRow);
HWY_EXPORT(DepthChangeNormalsRow);

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
void gradientNormalsRow(const GradientRow& row) { HWY_DYNAMIC_DISPATCH(GradientNormalsRow)(row); }
void depthChangeNormalsRow(const GradientRow& row) {
  HWY_DYNAMIC_DISPATCH(DepthChangeNormalsRow)(row);
}

}  // namespace shapesense::detail
#endif  // HWY_ONCE
