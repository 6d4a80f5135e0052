// The gradient modes' row kernels (see normal_kernels.h), compiled once per Highway target.
// Float work keeps the scalar definition's order of operations, as separate multiplies and adds
// (Highway's MulAdd would fuse them and round differently), so every target gives the bits of
// the scalar loops; min / max only ever see NaN in lanes whose result is masked out.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "normals/normal_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// (foreach_target.h first: it re-includes this file once per target.)
#include "hwy/highway.h"
#include "normals/block_transpose-inl.h"
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

HWY_EXPORT(GradientNormalsRow);
HWY_EXPORT(DepthChangeNormalsRow);

void gradientNormalsRow(const GradientRow& row) { HWY_DYNAMIC_DISPATCH(GradientNormalsRow)(row); }
void depthChangeNormalsRow(const GradientRow& row) {
  HWY_DYNAMIC_DISPATCH(DepthChangeNormalsRow)(row);
}

}  // namespace shapesense::detail
#endif  // HWY_ONCE
