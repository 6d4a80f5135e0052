#include "shapesense/core/normals/normals.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include "cpu_dispatch.h"

namespace shapesense {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

inline bool validZ(float z) { return z > 0.0f; }  // NaN compares false

// Four uint32 lanes (X, Y, Z, count) of one element of the packed integral image:
// one 16-byte load fetches a corner for every channel, one vector op combines them.
using v4u = std::uint32_t __attribute__((vector_size(16)));
using v4i = std::int32_t __attribute__((vector_size(16)));
using v4f = float __attribute__((vector_size(16)));

inline v4u load4(const std::uint32_t* p) {
  v4u r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
inline void store4(std::uint32_t* p, v4u x) { std::memcpy(p, &x, sizeof x); }

// 0.1 mm fixed point, 0 where invalid (branch-free select before the conversion).
inline std::uint32_t fixed(float x, bool valid) {
  return static_cast<std::uint32_t>(static_cast<std::int32_t>((valid ? x : 0.0f) * 1e4f));
}

enum Mode { kCov = 0, kGrad = 1, kDepth = 2 };

// Wrapped four-corner difference of a uint32/int32 integral image: exact whenever the true window
// sum fits, whatever the (overflowing) image-wide sums are.
inline std::uint32_t rectU32(const std::uint32_t* a, const std::uint32_t* b, const std::uint32_t* c,
                             const std::uint32_t* d) {
  return *d - *b - *c + *a;
}

#if defined(__SSE2__)
// Four (x, y, z) triples from planes X, Y, Z to 12 consecutive floats (a CV_32FC3 row).
inline void storeInterleaved(__m128 X, __m128 Y, __m128 Z, float* out) {
  const __m128 t0 = _mm_unpacklo_ps(X, Y), t1 = _mm_unpackhi_ps(X, Y);  // x0 y0 x1 y1 | x2 y2 x3 y3
  const __m128 o0 =
      _mm_shuffle_ps(t0, _mm_shuffle_ps(Z, X, _MM_SHUFFLE(1, 1, 0, 0)), _MM_SHUFFLE(2, 0, 1, 0));
  const __m128 o1 =
      _mm_shuffle_ps(_mm_shuffle_ps(Y, Z, _MM_SHUFFLE(1, 1, 1, 1)), t1, _MM_SHUFFLE(1, 0, 2, 0));
  const __m128 o2 =
      _mm_shuffle_ps(_mm_shuffle_ps(Z, X, _MM_SHUFFLE(3, 3, 2, 2)),
                     _mm_shuffle_ps(Y, Z, _MM_SHUFFLE(3, 3, 3, 3)), _MM_SHUFFLE(2, 0, 2, 0));
  _mm_storeu_ps(out, o0);
  _mm_storeu_ps(out + 4, o1);
  _mm_storeu_ps(out + 8, o2);
}
#endif

#if defined(__SSE2__)
// Unit normals of pixels u..u+3 facing the camera (n . ray < 0, ray = ((u-cx)/fx, (v-cy)/fy, 1):
// the sign of n . X for every point X with depth), NaN where the unnormalised normal (nx, ny, nz)
// is (near) zero; branch-free, interleaved into 12 floats of the CV_32FC3 output row.
inline void normalize4(__m128 nx, __m128 ny, __m128 nz, int u, float cx, float ifx, float ry,
                       float* out) {
  const __m128 sign = _mm_set1_ps(-0.0f), zero = _mm_setzero_ps();
  const __m128 nan = _mm_set1_ps(kNaN), eps = _mm_set1_ps(1e-20f), one = _mm_set1_ps(1.0f);
  const __m128 uf =
      _mm_add_ps(_mm_set1_ps(static_cast<float>(u)), _mm_set_ps(3.0f, 2.0f, 1.0f, 0.0f));
  const __m128 len2 =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, nx), _mm_mul_ps(ny, ny)), _mm_mul_ps(nz, nz));
  const __m128 ok = _mm_cmpgt_ps(len2, eps);
  const __m128 rx = _mm_mul_ps(_mm_sub_ps(uf, _mm_set1_ps(cx)), _mm_set1_ps(ifx));
  const __m128 dot =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, rx), _mm_mul_ps(ny, _mm_set1_ps(ry))), nz);
  __m128 k = _mm_div_ps(one, _mm_sqrt_ps(_mm_max_ps(len2, eps)));
  k = _mm_xor_ps(k, _mm_and_ps(sign, _mm_cmpgt_ps(dot, zero)));  // face the camera
  k = _mm_or_ps(_mm_and_ps(ok, k), _mm_andnot_ps(ok, nan));
  storeInterleaved(_mm_mul_ps(nx, k), _mm_mul_ps(ny, k), _mm_mul_ps(nz, k), out + 3 * u);
}
#endif

// normalize4() for pixels begin..cols-1 of a row of unnormalised normals (x, y, z planes).
void normalizeRow(const float* nx_row, const float* ny_row, const float* nz_row, float cx,
                  float ifx, float ry, int begin, int cols, float* out) {
  int u = begin;
#if defined(__SSE2__)
  for (; u + 4 <= cols; u += 4)
    normalize4(_mm_loadu_ps(nx_row + u), _mm_loadu_ps(ny_row + u), _mm_loadu_ps(nz_row + u), u, cx,
               ifx, ry, out);
#endif
  for (; u < cols; ++u) {
    const float x = nx_row[u], y = ny_row[u], z = nz_row[u];
    const float len2 = x * x + y * y + z * z;
    float* o = out + 3 * u;
    if (!(len2 > 1e-20f)) {
      o[0] = o[1] = o[2] = kNaN;
      continue;
    }
    float k = 1.0f / std::sqrt(len2);
    if (x * (static_cast<float>(u) - cx) * ifx + y * ry + z > 0.0f) k = -k;
    o[0] = x * k;
    o[1] = y * k;
    o[2] = z * k;
  }
}

#if defined(__SSE2__)
// The window cache and the row's inputs of the gradient modes' row loop (see runGradient).
struct RowWindows {
  float* row_above;  // window-mean cache (planar: X, Y, Z means, count) of the rows of centres
  float* row_here;   // v - 1, v, v + 1
  float* row_below;
  int* rad_above;  // the radius each cached centre holds, 0 = none
  int* rad_here;
  int* rad_below;
  const std::uint32_t* const* irow;  // integral rows (4 uint32 per element: X, Y, Z, count)
  const int* rr;                     // this row's window radii, 0 = invalid pixel
  const int* min_count;              // fewest valid pixels per radius
  int cols, v;
  float fx, fy, cx, cy;  // intrinsics
  float ifx, ry;         // normalisation: ray x = (u - cx) * ifx, ray y of this row
  float* out;            // the CV_32FC3 output row
};

// quad() of runGradient with a radius per lane: lane k holds the window of radius rl[k] of
// centre x + k (L uint32 per integral element, K floats per cached window).
template <int M>
void quadLanes(const RowWindows& g, float* means, int* radii, int x, int y, __m128i rl) {
  constexpr int L = M == kGrad ? 4 : 2, K = M == kGrad ? 4 : 2;
  const int cols = g.cols;
  _mm_storeu_si128(reinterpret_cast<__m128i*>(radii + x), rl);
  alignas(16) int r4[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(r4), rl);
  auto ld = [](const std::uint32_t* p) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
  };
  __m128i s[4];  // lane k's window sum in the low L uint32
  for (int k = 0; k < 4; ++k) {
    const int r = r4[k];
    const std::ptrdiff_t dh = (2 * r + 1) * L;
    const std::uint32_t* a = g.irow[y - r] + (x + k - r) * L;
    const std::uint32_t* c = g.irow[y + r + 1] + (x + k - r) * L;
    s[k] = _mm_add_epi32(_mm_sub_epi32(_mm_sub_epi32(ld(c + dh), ld(a + dh)), ld(c)), ld(a));
  }
  __m128i count;
  __m128 chan[3];
  if constexpr (M == kGrad) {  // as quad()
    const __m128i t0 = _mm_unpacklo_epi32(s[0], s[1]), t1 = _mm_unpacklo_epi32(s[2], s[3]);
    const __m128i t2 = _mm_unpackhi_epi32(s[0], s[1]), t3 = _mm_unpackhi_epi32(s[2], s[3]);
    chan[0] = _mm_cvtepi32_ps(_mm_unpacklo_epi64(t0, t1));
    chan[1] = _mm_cvtepi32_ps(_mm_unpackhi_epi64(t0, t1));
    chan[2] = _mm_cvtepi32_ps(_mm_unpacklo_epi64(t2, t3));
    count = _mm_unpackhi_epi64(t2, t3);
  } else {
    const __m128 s01 = _mm_castsi128_ps(_mm_unpacklo_epi64(s[0], s[1]));
    const __m128 s23 = _mm_castsi128_ps(_mm_unpacklo_epi64(s[2], s[3]));
    chan[0] = _mm_cvtepi32_ps(_mm_castps_si128(_mm_shuffle_ps(s01, s23, _MM_SHUFFLE(3, 1, 3, 1))));
    count = _mm_castps_si128(_mm_shuffle_ps(s01, s23, _MM_SHUFFLE(2, 0, 2, 0)));
  }
  const __m128 nf = _mm_cvtepi32_ps(count);
  const __m128 inv_n =
      _mm_and_ps(_mm_div_ps(_mm_set1_ps(1.0f), nf), _mm_cmpgt_ps(nf, _mm_setzero_ps()));
  for (int k = 0; k < K - 1; ++k) _mm_storeu_ps(means + k * cols + x, _mm_mul_ps(chan[k], inv_n));
  _mm_storeu_ps(means + (K - 1) * cols + x, nf);
}

// four() of runGradient where lane k's radius is rl[k] (lanes: the valid lanes), with the same
// operations. The left windows are read before the right ones are ensured: the right windows of
// lanes k can evict the left windows of lanes k + 2 (same centres, other radii). Out of line:
// rare, and runGradient's loop stays small enough to be inlined whole.
template <int M>
__attribute__((noinline)) void fourLanes(const RowWindows& g, int u, __m128i rl, __m128i lanes,
                                         __m128& nx, __m128& ny, __m128& nz) {
  constexpr int K = M == kGrad ? 4 : 2;
  const int cols = g.cols, v = g.v;
  auto ensure = [&](float* means, int* radii, int x, int y) {
    const __m128i have = _mm_loadu_si128(reinterpret_cast<const __m128i*>(radii + x));
    if (_mm_movemask_epi8(_mm_cmpeq_epi32(have, rl)) != 0xFFFF)
      quadLanes<M>(g, means, radii, x, y, rl);
  };
  __m128 lw[K], rw[K], uw[K], dw[K];
  ensure(g.row_here, g.rad_here, u - 1, v);
  for (int k = 0; k < K; ++k) lw[k] = _mm_loadu_ps(g.row_here + k * cols + u - 1);
  ensure(g.row_here, g.rad_here, u + 1, v);
  for (int k = 0; k < K; ++k) rw[k] = _mm_loadu_ps(g.row_here + k * cols + u + 1);
  ensure(g.row_above, g.rad_above, u, v - 1);
  ensure(g.row_below, g.rad_below, u, v + 1);
  for (int k = 0; k < K; ++k) {
    uw[k] = _mm_loadu_ps(g.row_above + k * cols + u);
    dw[k] = _mm_loadu_ps(g.row_below + k * cols + u);
  }
  alignas(16) int r4[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(r4), rl);
  const __m128 min_n =
      _mm_setr_ps(static_cast<float>(g.min_count[r4[0]]), static_cast<float>(g.min_count[r4[1]]),
                  static_cast<float>(g.min_count[r4[2]]), static_cast<float>(g.min_count[r4[3]]));
  const __m128 nmin =
      _mm_min_ps(_mm_min_ps(lw[K - 1], rw[K - 1]), _mm_min_ps(uw[K - 1], dw[K - 1]));
  const __m128 ok = _mm_and_ps(_mm_castsi128_ps(lanes), _mm_cmpge_ps(nmin, min_n));
  if constexpr (M == kGrad) {
    const __m128 hx = _mm_sub_ps(rw[0], lw[0]), hy = _mm_sub_ps(rw[1], lw[1]),
                 hz = _mm_sub_ps(rw[2], lw[2]);
    const __m128 tx = _mm_sub_ps(dw[0], uw[0]), ty = _mm_sub_ps(dw[1], uw[1]),
                 tz = _mm_sub_ps(dw[2], uw[2]);
    nx = _mm_sub_ps(_mm_mul_ps(hy, tz), _mm_mul_ps(hz, ty));
    ny = _mm_sub_ps(_mm_mul_ps(hz, tx), _mm_mul_ps(hx, tz));
    nz = _mm_sub_ps(_mm_mul_ps(hx, ty), _mm_mul_ps(hy, tx));
  } else {
    const __m128 half = _mm_set1_ps(0.5f), quarter = _mm_set1_ps(0.25f);
    const __m128 zl = lw[0], zr = rw[0], zu_ = uw[0], zd = dw[0];
    const __m128 du = _mm_mul_ps(half, _mm_sub_ps(zr, zl));
    const __m128 dv = _mm_mul_ps(half, _mm_sub_ps(zd, zu_));
    const __m128 zm = _mm_mul_ps(quarter, _mm_add_ps(_mm_add_ps(_mm_add_ps(zl, zr), zu_), zd));
    const __m128 dx = _mm_sub_ps(
        _mm_add_ps(_mm_set1_ps(static_cast<float>(u)), _mm_set_ps(3.0f, 2.0f, 1.0f, 0.0f)),
        _mm_set1_ps(g.cx));
    const __m128 vdy = _mm_set1_ps(static_cast<float>(v) - g.cy);
    nx = _mm_mul_ps(_mm_set1_ps(g.fx), du);
    ny = _mm_mul_ps(_mm_set1_ps(g.fy), dv);
    nz = _mm_xor_ps(_mm_set1_ps(-0.0f),
                    _mm_add_ps(_mm_add_ps(zm, _mm_mul_ps(dx, du)), _mm_mul_ps(vdy, dv)));
  }
  nx = _mm_and_ps(ok, nx);
  ny = _mm_and_ps(ok, ny);
  nz = _mm_and_ps(ok, nz);
}

#endif

#if defined(SHAPESENSE_AVX2_PATHS)
// The 3D-gradient mode's eight-pixel step (AVX2: pixels u..u+7 whose valid lanes share the radius
// r), with the operations of the four-pixel SSE2 step in the same order, lane for lane: the same
// bits. AVX2 only, never FMA (a fused multiply-add would round differently: the build has
// -ffp-contract=off, and no FMA intrinsic is used). Compiled for AVX2 (lambdas included) whatever
// the build flags; called only where the CPU has it.
#pragma GCC push_options
#pragma GCC target("avx2")

// The windows of radius r of centres x..x+7 of the row of centres y, into the cache.
inline void gradOct(const RowWindows& g, float* means, int* radii, int x, int y, int r) {
  const int cols = g.cols;
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(radii + x), _mm256_set1_epi32(r));
  const std::ptrdiff_t dh = (2 * r + 1) * 4;
  const std::uint32_t* a = g.irow[y - r] + (x - r) * 4;
  const std::uint32_t* c = g.irow[y + r + 1] + (x - r) * 4;
  auto ld = [&](const std::uint32_t* p) {  // (capturing: no static invoker outside AVX2)
    return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
  };
  auto sum = [&](int off) {  // the window sums of two consecutive centres
    return _mm256_add_epi32(
        _mm256_sub_epi32(_mm256_sub_epi32(ld(c + dh + off), ld(a + dh + off)), ld(c + off)),
        ld(a + off));
  };
  const __m256i e01 = sum(0), e23 = sum(8), e45 = sum(16), e67 = sum(24);
  // Centres k (low half) and k + 4 (high half), then the SSE2 step's 4x4 transpose in each half.
  const __m256i s0 = _mm256_permute2x128_si256(e01, e45, 0x20);
  const __m256i s1 = _mm256_permute2x128_si256(e01, e45, 0x31);
  const __m256i s2 = _mm256_permute2x128_si256(e23, e67, 0x20);
  const __m256i s3 = _mm256_permute2x128_si256(e23, e67, 0x31);
  const __m256i t0 = _mm256_unpacklo_epi32(s0, s1), t1 = _mm256_unpacklo_epi32(s2, s3);
  const __m256i t2 = _mm256_unpackhi_epi32(s0, s1), t3 = _mm256_unpackhi_epi32(s2, s3);
  const __m256 nf = _mm256_cvtepi32_ps(_mm256_unpackhi_epi64(t2, t3));
  const __m256 inv_n = _mm256_and_ps(_mm256_div_ps(_mm256_set1_ps(1.0f), nf),
                                     _mm256_cmp_ps(nf, _mm256_setzero_ps(), _CMP_GT_OQ));
  _mm256_storeu_ps(means + x,
                   _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_unpacklo_epi64(t0, t1)), inv_n));
  _mm256_storeu_ps(means + cols + x,
                   _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_unpackhi_epi64(t0, t1)), inv_n));
  _mm256_storeu_ps(means + 2 * cols + x,
                   _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_unpacklo_epi64(t2, t3)), inv_n));
  _mm256_storeu_ps(means + 3 * cols + x, nf);
}

inline void gradEight(const RowWindows& g, int u, int r) {
  const int cols = g.cols, v = g.v;
  const __m256i rv = _mm256_set1_epi32(r);
  auto ensure = [&](float* means, int* radii, int x, int y) {
    const __m256i have = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(radii + x));
    if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(have, rv)) != -1) gradOct(g, means, radii, x, y, r);
  };
  ensure(g.row_here, g.rad_here, u - 1, v);
  ensure(g.row_here, g.rad_here, u + 1, v);
  ensure(g.row_above, g.rad_above, u, v - 1);
  ensure(g.row_below, g.rad_below, u, v + 1);
  auto l = [&](int k) { return _mm256_loadu_ps(g.row_here + k * cols + u - 1); };
  auto rt = [&](int k) { return _mm256_loadu_ps(g.row_here + k * cols + u + 1); };
  auto up = [&](int k) { return _mm256_loadu_ps(g.row_above + k * cols + u); };
  auto dn = [&](int k) { return _mm256_loadu_ps(g.row_below + k * cols + u); };
  const __m256 lanes = _mm256_castsi256_ps(
      _mm256_cmpeq_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(g.rr + u)), rv));
  const __m256 nmin = _mm256_min_ps(_mm256_min_ps(l(3), rt(3)), _mm256_min_ps(up(3), dn(3)));
  const __m256 ok = _mm256_and_ps(
      lanes, _mm256_cmp_ps(nmin, _mm256_set1_ps(static_cast<float>(g.min_count[r])), _CMP_GE_OQ));
  const __m256 hx = _mm256_sub_ps(rt(0), l(0)), hy = _mm256_sub_ps(rt(1), l(1)),
               hz = _mm256_sub_ps(rt(2), l(2));
  const __m256 tx = _mm256_sub_ps(dn(0), up(0)), ty = _mm256_sub_ps(dn(1), up(1)),
               tz = _mm256_sub_ps(dn(2), up(2));
  const __m256 nx = _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(hy, tz), _mm256_mul_ps(hz, ty)));
  const __m256 ny = _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(hz, tx), _mm256_mul_ps(hx, tz)));
  const __m256 nz = _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(hx, ty), _mm256_mul_ps(hy, tx)));
  // normalize4() on eight lanes.
  const __m256 sign = _mm256_set1_ps(-0.0f), zero = _mm256_setzero_ps();
  const __m256 nan = _mm256_set1_ps(kNaN), eps = _mm256_set1_ps(1e-20f);
  const __m256 uf = _mm256_add_ps(_mm256_set1_ps(static_cast<float>(u)),
                                  _mm256_setr_ps(0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f));
  const __m256 len2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, nx), _mm256_mul_ps(ny, ny)),
                                    _mm256_mul_ps(nz, nz));
  const __m256 valid = _mm256_cmp_ps(len2, eps, _CMP_GT_OQ);
  const __m256 rx = _mm256_mul_ps(_mm256_sub_ps(uf, _mm256_set1_ps(g.cx)), _mm256_set1_ps(g.ifx));
  const __m256 dot = _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(nx, rx), _mm256_mul_ps(ny, _mm256_set1_ps(g.ry))), nz);
  __m256 k = _mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_sqrt_ps(_mm256_max_ps(len2, eps)));
  k = _mm256_xor_ps(k, _mm256_and_ps(sign, _mm256_cmp_ps(dot, zero, _CMP_GT_OQ)));
  k = _mm256_or_ps(_mm256_and_ps(valid, k), _mm256_andnot_ps(valid, nan));
  const __m256 ox = _mm256_mul_ps(nx, k), oy = _mm256_mul_ps(ny, k), oz = _mm256_mul_ps(nz, k);
  float* o = g.out + 3 * u;
  storeInterleaved(_mm256_castps256_ps128(ox), _mm256_castps256_ps128(oy),
                   _mm256_castps256_ps128(oz), o);
  storeInterleaved(_mm256_extractf128_ps(ox, 1), _mm256_extractf128_ps(oy, 1),
                   _mm256_extractf128_ps(oz, 1), o + 12);
}

// The 3D-gradient integral row of depth input, eight pixels per step while u + 8 < cols (the
// SSE2 loop's operations on eight lanes; the running sums are uint32, so any order of the
// additions gives the same bits). `acc` (X, Y, Z, count) is the running sum of the row so far.
// Returns the first pixel not done.
int gradIntegralRowAvx2(const float* zrow, const float* rx, float ry, const std::uint32_t* above,
                        std::uint32_t* row, int cols, __m128i& acc) {
  const __m256 scale = _mm256_set1_ps(1e4f), zero = _mm256_setzero_ps(), vry = _mm256_set1_ps(ry);
  const __m256i one = _mm256_set1_epi32(1);
  __m256i run = _mm256_broadcastsi128_si256(acc);  // the running sum in both halves
  int u = 0;
  for (; u + 8 < cols; u += 8) {
    const __m256 z = _mm256_loadu_ps(zrow + u);
    const __m256i ok = _mm256_castps_si256(_mm256_cmp_ps(z, zero, _CMP_GT_OQ));
    auto toFixed = [&](__m256 c) {
      return _mm256_and_si256(_mm256_cvttps_epi32(_mm256_mul_ps(c, scale)), ok);
    };
    const __m256i fx = toFixed(_mm256_mul_ps(_mm256_loadu_ps(rx + u), z));
    const __m256i fy = toFixed(_mm256_mul_ps(vry, z)), fz = toFixed(z);
    const __m256i count = _mm256_and_si256(ok, one);
    // Elements (x, y, z, count) of pixels k (low half) and k + 4 (high half).
    const __m256i xy01 = _mm256_unpacklo_epi32(fx, fy), zc01 = _mm256_unpacklo_epi32(fz, count);
    const __m256i xy23 = _mm256_unpackhi_epi32(fx, fy), zc23 = _mm256_unpackhi_epi32(fz, count);
    const __m256i p0 = _mm256_unpacklo_epi64(xy01, zc01), p1 = _mm256_unpackhi_epi64(xy01, zc01);
    const __m256i p2 = _mm256_unpacklo_epi64(xy23, zc23), p3 = _mm256_unpackhi_epi64(xy23, zc23);
    // Prefix sums within each half, then the low half's total into the high half, then the row's.
    const __m256i q1 = _mm256_add_epi32(p0, p1), q2 = _mm256_add_epi32(q1, p2);
    const __m256i q3 = _mm256_add_epi32(q2, p3);
    const __m256i carry = _mm256_add_epi32(run, _mm256_permute2x128_si256(q3, q3, 0x08));
    const __m256i c0 = _mm256_add_epi32(p0, carry), c1 = _mm256_add_epi32(q1, carry);
    const __m256i c2 = _mm256_add_epi32(q2, carry), c3 = _mm256_add_epi32(q3, carry);
    run = _mm256_permute2x128_si256(c3, c3, 0x11);
    auto put = [&](int k, __m256i e) {  // pixels u + k, u + k + 1
      const auto* up = reinterpret_cast<const __m256i*>(above + (u + k + 1) * 4);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(row + (u + k + 1) * 4),
                          _mm256_add_epi32(_mm256_loadu_si256(up), e));
    };
    put(0, _mm256_permute2x128_si256(c0, c1, 0x20));
    put(2, _mm256_permute2x128_si256(c2, c3, 0x20));
    put(4, _mm256_permute2x128_si256(c0, c1, 0x31));
    put(6, _mm256_permute2x128_si256(c2, c3, 0x31));
  }
  acc = _mm256_castsi256_si128(run);
  return u;
}

// markSteps() on eight pixels per step, the SSE2 steps' operations on eight lanes (the same
// flags): the vertical steps of row v (up to the returned *u_vertical), then the horizontal ones
// between neighbours from pixel 1 (up to *u_horizontal); the pixels that follow a hole are listed
// in after_hole (their steps across the gap are the caller's).
void markStepsRowAvx2(const float* zrow, float* last_z, int* last_v, int v, int cols, int max_gap,
                      float factor, float noise_k, std::uint8_t* steps, std::size_t step_stride,
                      int* u_vertical, int* u_horizontal, int* after_hole, int* n_after_hole) {
  const __m256 vfactor = _mm256_set1_ps(factor), vnoise = _mm256_set1_ps(noise_k);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256i vv = _mm256_set1_epi32(v), gap_limit = _mm256_set1_epi32(max_gap + 2);
  int u = 0;
  for (; u + 8 <= cols; u += 8) {
    const __m256 z = _mm256_loadu_ps(zrow + u), za = _mm256_loadu_ps(last_z + u);
    const __m256i lv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(last_v + u));
    const __m256 ok = _mm256_cmp_ps(z, zero, _CMP_GT_OQ);
    const __m256i gap1 = _mm256_sub_epi32(vv, lv);
    const __m256 zmin = _mm256_min_ps(za, z);
    const __m256 by_factor = _mm256_mul_ps(_mm256_mul_ps(vfactor, zmin), _mm256_cvtepi32_ps(gap1));
    const __m256 by_noise = _mm256_mul_ps(_mm256_mul_ps(vnoise, zmin), zmin);
    const __m256 threshold = _mm256_max_ps(by_noise, by_factor);
    const __m256 step =
        _mm256_cmp_ps(_mm256_and_ps(_mm256_sub_ps(z, za), abs_mask), threshold, _CMP_GT_OQ);
    const __m256 near = _mm256_castsi256_ps(_mm256_cmpgt_epi32(gap_limit, gap1));
    const int marks = _mm256_movemask_ps(_mm256_and_ps(_mm256_and_ps(ok, near), step));
    _mm256_storeu_ps(last_z + u, _mm256_blendv_ps(za, z, ok));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(last_v + u),
                        _mm256_blendv_epi8(lv, vv, _mm256_castps_si256(ok)));
    if (marks == 0) continue;
    alignas(32) int rows_above[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(rows_above), lv);
    for (int k = 0; k < 8; ++k)
      if (marks & (1 << k))
        steps[static_cast<std::size_t>(rows_above[k]) * step_stride + u + k] = 1;
  }
  *u_vertical = u;
  std::uint8_t* s = steps + static_cast<std::size_t>(v) * step_stride;
  int n = 0;
  for (u = 1; u + 8 <= cols; u += 8) {
    const __m256 z = _mm256_loadu_ps(zrow + u), zl = _mm256_loadu_ps(zrow + u - 1);
    const __m256 zmin = _mm256_min_ps(zl, z);
    const __m256 by_factor = _mm256_mul_ps(vfactor, zmin);
    const __m256 by_noise = _mm256_mul_ps(_mm256_mul_ps(vnoise, zmin), zmin);
    const __m256 threshold = _mm256_max_ps(by_noise, by_factor);
    const __m256 ok = _mm256_cmp_ps(z, zero, _CMP_GT_OQ), okl = _mm256_cmp_ps(zl, zero, _CMP_GT_OQ);
    const __m256 step = _mm256_and_ps(
        _mm256_and_ps(ok, okl),
        _mm256_cmp_ps(_mm256_and_ps(_mm256_sub_ps(z, zl), abs_mask), threshold, _CMP_GT_OQ));
    const __m256i si = _mm256_castps_si256(step);
    __m128i b = _mm_packs_epi32(_mm256_castsi256_si128(si), _mm256_extracti128_si256(si, 1));
    b = _mm_and_si128(_mm_packs_epi16(b, b), _mm_set1_epi8(1));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(s + u - 1), b);
    int holes = _mm256_movemask_ps(_mm256_andnot_ps(okl, ok));
    while (holes != 0) {
      after_hole[n++] = u + __builtin_ctz(static_cast<unsigned>(holes));
      holes &= holes - 1;
    }
  }
  *u_horizontal = u;
  *n_after_hole = n;
}

// stepDistance() pieces, sixteen pixels per step: d = far except 0 on step marks (returns the
// first pixel not done); the fold of the row o before / after in the pass into d[1 .. cols - 2]
// (returns the first pixel not done); the running-minimum scan (dir > 0: forward from pixel 0,
// else backward from cols - 1; returns the first pixel not scanned, for the serial tail). The
// minima are exact, so these give the values of the SSE2 and scalar loops.
int stepInitAvx2(const std::uint8_t* st, std::int16_t* d, int cols, std::int16_t far) {
  const __m256i vfar = _mm256_set1_epi16(far);
  int u = 0;
  for (; u + 16 <= cols; u += 16) {
    const __m256i marks =
        _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(st + u)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(d + u),
                        _mm256_and_si256(_mm256_cmpeq_epi16(marks, _mm256_setzero_si256()), vfar));
  }
  return u;
}

int stepFoldAvx2(std::int16_t* d, const std::int16_t* o, int cols) {
  auto ld = [&](const std::int16_t* p) {
    return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
  };
  const __m256i one = _mm256_set1_epi16(1);
  int u = 1;
  for (; u + 17 <= cols; u += 16) {
    const __m256i m = _mm256_add_epi16(
        _mm256_min_epi16(_mm256_min_epi16(ld(o + u - 1), ld(o + u)), ld(o + u + 1)), one);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(d + u), _mm256_min_epi16(m, ld(d + u)));
  }
  return u;
}

int stepScanAvx2(std::int16_t* d, int cols, int dir) {
  const __m256i big = _mm256_set1_epi16(0x7fff);  // "no value": saturates when incremented
  // Lane i takes lane i - n (up) or i + n (down) across the halves; `big` shifts in.
  auto up = [&](__m256i x, auto n) {
    return _mm256_alignr_epi8(x, _mm256_permute2x128_si256(x, big, 0x02),
                              16 - 2 * decltype(n)::value);
  };
  auto down = [&](__m256i x, auto n) {
    return _mm256_alignr_epi8(_mm256_permute2x128_si256(x, big, 0x31), x, 2 * decltype(n)::value);
  };
  using one = std::integral_constant<int, 1>;
  using two = std::integral_constant<int, 2>;
  using four = std::integral_constant<int, 4>;
  using eight = std::integral_constant<int, 8>;
  auto k = [&](int n) { return _mm256_set1_epi16(static_cast<short>(n)); };
  __m256i carry = big;  // the value before the block, in every lane
  if (dir > 0) {
    const __m256i ramp = _mm256_setr_epi16(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16);
    int u = 0;
    for (; u + 16 <= cols; u += 16) {
      auto* p = reinterpret_cast<__m256i*>(d + u);
      __m256i x = _mm256_loadu_si256(p);
      x = _mm256_min_epi16(x, _mm256_adds_epi16(up(x, one{}), k(1)));
      x = _mm256_min_epi16(x, _mm256_adds_epi16(up(x, two{}), k(2)));
      x = _mm256_min_epi16(x, _mm256_adds_epi16(up(x, four{}), k(4)));
      x = _mm256_min_epi16(x, _mm256_adds_epi16(up(x, eight{}), k(8)));
      const __m256i next =
          _mm256_min_epi16(_mm256_set1_epi16(static_cast<short>(_mm256_extract_epi16(x, 15))),
                           _mm256_adds_epi16(carry, k(16)));
      _mm256_storeu_si256(p, _mm256_min_epi16(x, _mm256_adds_epi16(carry, ramp)));
      carry = next;
    }
    return u;
  }
  const __m256i ramp_back =
      _mm256_setr_epi16(16, 15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1);
  int u = cols - 1;
  for (; u - 15 >= 0; u -= 16) {
    auto* p = reinterpret_cast<__m256i*>(d + u - 15);
    __m256i x = _mm256_loadu_si256(p);
    x = _mm256_min_epi16(x, _mm256_adds_epi16(down(x, one{}), k(1)));
    x = _mm256_min_epi16(x, _mm256_adds_epi16(down(x, two{}), k(2)));
    x = _mm256_min_epi16(x, _mm256_adds_epi16(down(x, four{}), k(4)));
    x = _mm256_min_epi16(x, _mm256_adds_epi16(down(x, eight{}), k(8)));
    const __m256i next =
        _mm256_min_epi16(_mm256_set1_epi16(static_cast<short>(_mm256_extract_epi16(x, 0))),
                         _mm256_adds_epi16(carry, k(16)));
    _mm256_storeu_si256(p, _mm256_min_epi16(x, _mm256_adds_epi16(carry, ramp_back)));
    carry = next;
  }
  return u;
}

// The gradient modes' window radii of a row (step (a) of runGradient), eight pixels per step with
// the scalar loop's operations (the selects as min / max: no NaN reaches them). Returns the first
// pixel not done.
int radiusRowAvx2(const float* zrow, const std::int16_t* dist, const float* colb, int cols,
                  float base_r, float const_r, float min_rf, float max_rf, float bv, int* rr) {
  const __m256 vbase = _mm256_set1_ps(base_r), vconst = _mm256_set1_ps(const_r);
  const __m256 half = _mm256_set1_ps(0.5f), vmin = _mm256_set1_ps(min_rf);
  const __m256 vmax = _mm256_set1_ps(max_rf), vbv = _mm256_set1_ps(bv);
  const __m256i two = _mm256_set1_epi32(2);
  int u = 0;
  for (; u + 8 <= cols; u += 8) {
    const __m256 zp = _mm256_loadu_ps(zrow + u);
    const __m256 ok = _mm256_cmp_ps(zp, _mm256_setzero_ps(), _CMP_GT_OQ);
    __m256 r =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(vbase, _mm256_and_ps(ok, zp)), vconst), half);
    r = _mm256_max_ps(r, vmin);
    r = _mm256_min_ps(r, vmax);
    r = _mm256_min_ps(r, _mm256_loadu_ps(colb + u));
    r = _mm256_min_ps(r, vbv);
    const __m256i d32 =
        _mm256_cvtepi16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(dist + u)));
    r = _mm256_min_ps(r, _mm256_cvtepi32_ps(_mm256_sub_epi32(d32, two)));
    const __m256 keep = _mm256_and_ps(ok, _mm256_cmp_ps(r, vmin, _CMP_GE_OQ));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(rr + u),
                        _mm256_and_si256(_mm256_cvttps_epi32(r), _mm256_castps_si256(keep)));
  }
  return u;
}

// compute()'s z of a depth row (mm -> m, NaN without depth), sixteen pixels per step with the
// SSE2 loop's operations. Returns the first pixel not done.
int depthRowAvx2(const std::uint16_t* d, float* zr, int cols) {
  const __m256 to_metres = _mm256_set1_ps(0.001f), zero = _mm256_setzero_ps();
  const __m256 nan = _mm256_set1_ps(kNaN);
  auto toZ = [&](__m128i mm16) {
    const __m256 metres = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(mm16)), to_metres);
    return _mm256_blendv_ps(nan, metres, _mm256_cmp_ps(metres, zero, _CMP_GT_OQ));
  };
  int u = 0;
  for (; u + 16 <= cols; u += 16) {
    _mm256_storeu_ps(zr + u, toZ(_mm_loadu_si128(reinterpret_cast<const __m128i*>(d + u))));
    _mm256_storeu_ps(zr + u + 8, toZ(_mm_loadu_si128(reinterpret_cast<const __m128i*>(d + u + 8))));
  }
  return u;
}

// gradEight() on the eight-pixel groups from pixel u on while their valid lanes share one radius
// and their windows lie inside the image (groups without valid pixels: NaN). Returns the first
// pixel not done (a group for the four-pixel steps, or the row's last pixels).
int gradRun(const RowWindows& g, int u) {
  const int cols = g.cols;
  for (; u + 8 <= cols; u += 8) {
    const __m256i rv8 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(g.rr + u));
    const int valid =
        ~_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(rv8, _mm256_setzero_si256()))) &
        255;
    if (valid == 0) {
      for (int k = 0; k < 3; ++k) _mm256_storeu_ps(g.out + 3 * u + 8 * k, _mm256_set1_ps(kNaN));
      continue;
    }
    const int r = g.rr[u + __builtin_ctz(static_cast<unsigned>(valid))];
    const int same =
        _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(rv8, _mm256_set1_epi32(r))));
    if ((valid & ~same) != 0 || u - 1 - r < 0 || u + 9 + r > cols) break;
    gradEight(g, u, r);
  }
  return u;
}

#pragma GCC pop_options

using detail::cpuHasAvx2;
#endif

}  // namespace

// Marks depth steps: between neighbouring valid pixels, and across runs of up to max_gap_px
// invalid pixels (Kinect shadows), the depth change exceeds max(factor * z * (gap+1),
// noise_steps * depthStep(z)). Only one pixel of each step pair is marked (left / top): every
// square window holding pixels of both sides holds a 4-adjacent pair across the step, hence a
// mark, so "no mark in the window" is exactly "the window does not straddle a step".
void NormalEstimator::markSteps() {
  const int rows = rows_, cols = cols_;
  // No clearing: the horizontal pass assigns every pixel of a row before the vertical pass of
  // later rows marks any of them.
  steps_.create(rows, cols, CV_8UC1);
  const float factor = static_cast<float>(params_.max_depth_change_factor);
  const float noise_k =
      static_cast<float>(params_.depth_change_noise_steps * params_.noise.disparity_step_px /
                         params_.noise.focal_baseline_px_m);
  const int max_gap = std::max(0, params_.max_gap_px);
  auto isStep = [&](float a, float b, int gap) {
    const float z = std::min(a, b);
    return std::fabs(a - b) > std::max(factor * z * static_cast<float>(gap + 1), noise_k * z * z);
  };
  last_z_.assign(cols, 0.0f);
  last_v_.assign(cols, -1000000);
  [[maybe_unused]] bool use_avx2 = false;  // AVX2 steps where the CPU has them
#if defined(SHAPESENSE_AVX2_PATHS)
  use_avx2 = simd_ && avx2_ && cpuHasAvx2();
  after_hole_.resize(static_cast<std::size_t>(cols));
#endif
  float* last_z = last_z_.data();
  int* last_v = last_v_.data();
  for (int v = 0; v < rows; ++v) {
    const float* zrow = zplane_.data() + static_cast<std::size_t>(v) * cols;
    auto* s = steps_.ptr<std::uint8_t>(v);
    // Vertical steps, against the last valid pixel above in the same column: branch-free, four
    // columns per SSE2 step (the same operations as the scalar loop, so the same flags); the
    // (rare) marks are written at once, as they go to the row of that pixel. No mark of this
    // pass lands in row v, which the horizontal pass below assigns.
    int u = 0;
    int u_horizontal = 1, n_after_hole = 0;  // AVX2: horizontal steps done, holes to follow up
#if defined(SHAPESENSE_AVX2_PATHS)
    if (use_avx2) {
      markStepsRowAvx2(zrow, last_z, last_v, v, cols, max_gap, factor, noise_k, steps_.data,
                       steps_.step, &u, &u_horizontal, after_hole_.data(), &n_after_hole);
    }
#endif
#if defined(__SSE2__)
    if (simd_) {
      const __m128 vfactor = _mm_set1_ps(factor), vnoise = _mm_set1_ps(noise_k);
      const __m128 zero = _mm_setzero_ps(), abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
      const __m128i vv = _mm_set1_epi32(v), gap_limit = _mm_set1_epi32(max_gap + 2);
      for (; u + 4 <= cols; u += 4) {
        const __m128 z = _mm_loadu_ps(zrow + u), za = _mm_loadu_ps(last_z + u);
        const __m128i lv = _mm_loadu_si128(reinterpret_cast<const __m128i*>(last_v + u));
        const __m128 ok = _mm_cmpgt_ps(z, zero);
        const __m128i gap1 = _mm_sub_epi32(vv, lv);  // gap + 1
        const __m128 zmin = _mm_min_ps(za, z);       // za < z ? za : z
        const __m128 by_factor = _mm_mul_ps(_mm_mul_ps(vfactor, zmin), _mm_cvtepi32_ps(gap1));
        const __m128 by_noise = _mm_mul_ps(_mm_mul_ps(vnoise, zmin), zmin);
        const __m128 threshold = _mm_max_ps(by_noise, by_factor);  // bf < bn ? bn : bf
        const __m128 step = _mm_cmpgt_ps(_mm_and_ps(_mm_sub_ps(z, za), abs_mask), threshold);
        const __m128 near =
            _mm_castsi128_ps(_mm_cmpgt_epi32(gap_limit, gap1));  // gap + 1 < max_gap + 2
        const int marks = _mm_movemask_ps(_mm_and_ps(_mm_and_ps(ok, near), step));
        _mm_storeu_ps(last_z + u, _mm_or_ps(_mm_and_ps(ok, z), _mm_andnot_ps(ok, za)));
        const __m128i oki = _mm_castps_si128(ok);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(last_v + u),
                         _mm_or_si128(_mm_and_si128(oki, vv), _mm_andnot_si128(oki, lv)));
        if (marks == 0) continue;
        alignas(16) int rows_above[4];
        _mm_store_si128(reinterpret_cast<__m128i*>(rows_above), lv);
        for (int k = 0; k < 4; ++k)
          if (marks & (1 << k)) steps_.ptr<std::uint8_t>(rows_above[k])[u + k] = 1;
      }
    }
#endif
    for (; u < cols; ++u) {
      const float z = zrow[u], za = last_z[u];
      const int lv = last_v[u];
      const int ok = validZ(z);
      const int gap = v - lv - 1;
      // isStep(z, za, gap), spelt out with selects.
      const float zmin = za < z ? za : z;
      const float by_factor = factor * zmin * static_cast<float>(gap + 1),
                  by_noise = noise_k * zmin * zmin;
      const float threshold = by_factor < by_noise ? by_noise : by_factor;
      const int step = std::fabs(z - za) > threshold;
      if (ok & (gap <= max_gap) & step) steps_.ptr<std::uint8_t>(lv)[u] = 1;
      last_z[u] = ok ? z : za;
      last_v[u] = ok ? v : lv;
    }
    // Horizontal steps, against the last valid pixel to the left: between neighbours branch-free
    // (four pixels per SSE2 step, the scalar loop's operations), then, at once, across the gap
    // before each (rarer) pixel that follows a hole. Those marks go left of the pixel, to places
    // already assigned.
    if (cols == 0) continue;
    auto acrossGap = [&](int u) {
      int prev_u = u - 2;  // u - 1 has no depth
      while (prev_u >= 0 && u - prev_u - 1 <= max_gap && !validZ(zrow[prev_u])) --prev_u;
      if (prev_u >= 0 && u - prev_u - 1 <= max_gap && isStep(zrow[u], zrow[prev_u], u - prev_u - 1))
        s[prev_u] = 1;
    };
    for (int i = 0; i < n_after_hole; ++i) acrossGap(after_hole_[i]);  // (marks left of them)
    u = u_horizontal;
#if defined(__SSE2__)
    if (simd_) {
      const __m128 vfactor = _mm_set1_ps(factor), vnoise = _mm_set1_ps(noise_k);
      const __m128 zero = _mm_setzero_ps(), abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
      for (; u + 4 <= cols; u += 4) {
        const __m128 z = _mm_loadu_ps(zrow + u), zl = _mm_loadu_ps(zrow + u - 1);
        const __m128 zmin = _mm_min_ps(zl, z);  // zl < z ? zl : z
        const __m128 by_factor = _mm_mul_ps(vfactor, zmin);
        const __m128 by_noise = _mm_mul_ps(_mm_mul_ps(vnoise, zmin), zmin);
        const __m128 threshold = _mm_max_ps(by_noise, by_factor);
        const __m128 ok = _mm_cmpgt_ps(z, zero), okl = _mm_cmpgt_ps(zl, zero);
        const __m128 step = _mm_and_ps(
            _mm_and_ps(ok, okl), _mm_cmpgt_ps(_mm_and_ps(_mm_sub_ps(z, zl), abs_mask), threshold));
        // 0 / -1 lanes to 0 / 1 bytes.
        __m128i b = _mm_packs_epi32(_mm_castps_si128(step), _mm_castps_si128(step));
        b = _mm_and_si128(_mm_packs_epi16(b, b), _mm_set1_epi8(1));
        const int flags = _mm_cvtsi128_si32(b);
        std::memcpy(s + u - 1, &flags, sizeof flags);
        const int after_hole = _mm_movemask_ps(_mm_andnot_ps(okl, ok));
        if (after_hole == 0) continue;
        for (int k = 0; k < 4; ++k)
          if (after_hole & (1 << k)) acrossGap(u + k);
      }
    }
#endif
    for (; u < cols; ++u) {
      const float z = zrow[u], zl = zrow[u - 1];
      const float zmin = zl < z ? zl : z;
      const float by_factor = factor * zmin, by_noise = noise_k * zmin * zmin;
      const float threshold = by_factor < by_noise ? by_noise : by_factor;
      s[u - 1] =
          static_cast<std::uint8_t>(validZ(z) & validZ(zl) & (std::fabs(z - zl) > threshold));
      if (validZ(z) && !validZ(zl)) acrossGap(u);
    }
    s[cols - 1] = 0;
  }
}

// Chessboard distance from every pixel to the nearest step mark, capped at `cap`: the square
// window of radius R centred on a pixel holds no mark iff R < distance, so one lookup replaces
// shrinking the window through the integral image. Two raster passes with the 3x3 unit mask,
// which is exact for the chessboard metric; each row's vertical terms vectorise, leaving a
// running-minimum scan along the row.
void NormalEstimator::stepDistance(int cap) {
  const int rows = steps_.rows, cols = steps_.cols;
  step_dist_.resize(static_cast<std::size_t>(rows) * cols);
  const auto far = static_cast<std::int16_t>(cap);
  // d[u] = min(d[u], d[u - dir] + 1) along the row, i.e. d[u] = min over k >= 0 of
  // (d[u - k dir] + k). The serial recurrence costs a dependent min per pixel; with SSE2 eight
  // pixels at a time take three shift-add-min steps (k < 8 within the block) and the block before
  // enters as its edge value + 1..8. Same minima, so same values.
  [[maybe_unused]] bool use_avx2 = false;  // AVX2 steps where the CPU has them
#if defined(SHAPESENSE_AVX2_PATHS)
  use_avx2 = simd_ && avx2_ && cpuHasAvx2();
#endif
  auto scan = [cols, use_avx2](std::int16_t* d, int dir) {
    int u = dir > 0 ? 0 : cols - 1;  // first pixel not yet scanned
#if defined(SHAPESENSE_AVX2_PATHS)
    if (use_avx2) u = stepScanAvx2(d, cols, dir);
#endif
#if defined(__SSE2__)
    const __m128i ramp = _mm_setr_epi16(1, 2, 3, 4, 5, 6, 7, 8);
    const __m128i ramp_back = _mm_setr_epi16(8, 7, 6, 5, 4, 3, 2, 1);
    const __m128i big = _mm_set1_epi16(0x7fff);  // "no value": saturates when incremented
    // Lanes shifted in by a block shift get `big` (the OR fills the zeroed lanes; shifted-in
    // lanes of `big >> or << n` are zero elsewhere).
    auto up = [&](__m128i x, auto n) {  // lane i takes lane i - n
      return _mm_or_si128(_mm_slli_si128(x, 2 * decltype(n)::value),
                          _mm_srli_si128(big, 16 - 2 * decltype(n)::value));
    };
    auto down = [&](__m128i x, auto n) {  // lane i takes lane i + n
      return _mm_or_si128(_mm_srli_si128(x, 2 * decltype(n)::value),
                          _mm_slli_si128(big, 16 - 2 * decltype(n)::value));
    };
    using one = std::integral_constant<int, 1>;
    using two = std::integral_constant<int, 2>;
    using four = std::integral_constant<int, 4>;
    if (use_avx2) {
      // done above
    } else if (dir > 0) {
      __m128i carry = big;  // d[u - 1] in every lane
      for (; u + 8 <= cols; u += 8) {
        auto* p = reinterpret_cast<__m128i*>(d + u);
        __m128i x = _mm_loadu_si128(p);
        x = _mm_min_epi16(x, _mm_adds_epi16(up(x, one{}), _mm_set1_epi16(1)));
        x = _mm_min_epi16(x, _mm_adds_epi16(up(x, two{}), _mm_set1_epi16(2)));
        x = _mm_min_epi16(x, _mm_adds_epi16(up(x, four{}), _mm_set1_epi16(4)));
        // The next carry, min(x[7], carry + 8) = the block's last value, without waiting for the
        // extract and broadcast of that value: the serial chain is one add and one min a block.
        const __m128i next =
            _mm_min_epi16(_mm_set1_epi16(static_cast<short>(_mm_extract_epi16(x, 7))),
                          _mm_adds_epi16(carry, _mm_set1_epi16(8)));
        x = _mm_min_epi16(x, _mm_adds_epi16(carry, ramp));
        _mm_storeu_si128(p, x);
        carry = next;
      }
    } else {
      __m128i carry = big;  // d[u + 1] in every lane
      for (; u - 7 >= 0; u -= 8) {
        auto* p = reinterpret_cast<__m128i*>(d + u - 7);
        __m128i x = _mm_loadu_si128(p);
        x = _mm_min_epi16(x, _mm_adds_epi16(down(x, one{}), _mm_set1_epi16(1)));
        x = _mm_min_epi16(x, _mm_adds_epi16(down(x, two{}), _mm_set1_epi16(2)));
        x = _mm_min_epi16(x, _mm_adds_epi16(down(x, four{}), _mm_set1_epi16(4)));
        const __m128i next =
            _mm_min_epi16(_mm_set1_epi16(static_cast<short>(_mm_extract_epi16(x, 0))),
                          _mm_adds_epi16(carry, _mm_set1_epi16(8)));
        x = _mm_min_epi16(x, _mm_adds_epi16(carry, ramp_back));
        _mm_storeu_si128(p, x);
        carry = next;
      }
    }
#endif
    const int end = dir > 0 ? cols : -1;
    if (u == (dir > 0 ? 0 : cols - 1)) u += dir;  // the first pixel has nothing before it
    for (; u != end; u += dir) {
      const auto next = static_cast<std::int16_t>(d[u - dir] + 1);
      d[u] = next < d[u] ? next : d[u];
    }
  };
  // Folds in the row before (forward) or after (backward) in the pass: neighbours u - 1, u, u + 1.
  auto fold = [cols, use_avx2](std::int16_t* d, const std::int16_t* o) {
    d[0] =
        std::min({d[0], static_cast<std::int16_t>(o[0] + 1), static_cast<std::int16_t>(o[1] + 1)});
    auto at = [&](int u) {
      const std::int16_t a = o[u - 1] < o[u] ? o[u - 1] : o[u];
      const std::int16_t m = static_cast<std::int16_t>((a < o[u + 1] ? a : o[u + 1]) + 1);
      d[u] = m < d[u] ? m : d[u];
    };
    // (Separate loops: a loop from a computed start does not vectorise.)
#if defined(SHAPESENSE_AVX2_PATHS)
    if (use_avx2) {
      for (int u = stepFoldAvx2(d, o, cols); u + 1 < cols; ++u) at(u);
    } else
#endif
    {
      for (int u = 1; u + 1 < cols; ++u) at(u);
    }
    d[cols - 1] = std::min({d[cols - 1], static_cast<std::int16_t>(o[cols - 1] + 1),
                            static_cast<std::int16_t>(o[cols - 2] + 1)});
  };
  for (int v = 0; v < rows; ++v) {
    const std::uint8_t* st = steps_.ptr<std::uint8_t>(v);
    std::int16_t* d = step_dist_.data() + static_cast<std::size_t>(v) * cols;
#if defined(SHAPESENSE_AVX2_PATHS)
    if (use_avx2) {
      for (int u = stepInitAvx2(st, d, cols, far); u < cols; ++u)
        d[u] = st[u] ? std::int16_t{0} : far;
    } else
#endif
    {
      for (int u = 0; u < cols; ++u) d[u] = st[u] ? std::int16_t{0} : far;
    }
    if (v > 0 && cols > 1) fold(d, d - cols);
    scan(d, 1);
  }
  for (int v = rows - 1; v >= 0; --v) {
    std::int16_t* d = step_dist_.data() + static_cast<std::size_t>(v) * cols;
    if (v + 1 < rows && cols > 1) fold(d, d + cols);
    scan(d, -1);
  }
}

// The covariance mode: an integral image of the nine first and second moments (double) and one of
// the valid count, evaluated at every pixel.
void NormalEstimator::runCovariance(cv::Mat& normals) {
  constexpr int K = 9;
  const int rows = rows_, cols = cols_;
  buildPoints();  // the moments need x and y too
  const std::size_t mstride = static_cast<std::size_t>(cols + 1);
  const std::size_t stride = mstride * K;
  mask_.resize(static_cast<std::size_t>(rows + 1) * mstride);
  std::fill(mask_.begin(), mask_.begin() + mstride, 0u);
  integral_.resize(static_cast<std::size_t>(rows + 1) * stride);
  std::fill(integral_.begin(), integral_.begin() + stride, 0.0);
  for (int v = 0; v < rows; ++v) {
    const auto* p = points_.ptr<cv::Vec3f>(v);
    std::uint32_t* mrow = mask_.data() + (v + 1) * mstride;
    const std::uint32_t* mabove = mrow - mstride;
    std::uint32_t macc = 0;
    mrow[0] = 0;
    for (int u = 0; u < cols; ++u) {
      macc += static_cast<std::uint32_t>(validZ(p[u][2]));
      mrow[u + 1] = mabove[u + 1] + macc;
    }
    double* row = integral_.data() + (v + 1) * stride;
    const double* above = row - stride;
    double acc[K] = {};
    for (int k = 0; k < K; ++k) row[k] = 0.0;
    for (int u = 0; u < cols; ++u) {
      const float zf = p[u][2];
      if (validZ(zf)) {
        const double x = p[u][0], y = p[u][1], z = zf;
        acc[0] += x;
        acc[1] += y;
        acc[2] += z;
        acc[3] += x * x;
        acc[4] += x * y;
        acc[5] += x * z;
        acc[6] += y * y;
        acc[7] += y * z;
        acc[8] += z * z;
      }
      double* out = row + (u + 1) * K;
      const double* a = above + (u + 1) * K;
      for (int k = 0; k < K; ++k) out[k] = a[k] + acc[k];
    }
  }

  const float base_r = static_cast<float>(params_.smoothing_radius_px);
  const bool scale_r = params_.depth_dependent_smoothing;
  const int min_r = std::max(1, params_.min_radius_px);
  const int max_r = std::max(min_r, params_.max_radius_px);
  const float min_frac = static_cast<float>(params_.min_valid_fraction);
  constexpr int reach = 0;  // the window is centred on the pixel (the gradient modes' are not)
  const std::uint32_t* Mi = mask_.data();

  stepDistance(std::min(max_r + 3, 30000));  // any cap above max_r + 1 + reach is "far"
  for (int v = 0; v < rows; ++v) {
    const auto* p = points_.ptr<cv::Vec3f>(v);
    const std::int16_t* dist = step_dist_.data() + static_cast<std::size_t>(v) * cols;
    auto* n_out = normals.ptr<cv::Vec3f>(v);
    const int border_v = std::min(v, rows - 1 - v) - reach;  // largest r inside the image
    for (int u = 0; u < cols; ++u) {
      const float z = p[u][2];
      if (!validZ(z)) continue;
      int r = static_cast<int>(base_r * (scale_r ? z : 1.0f) + 0.5f);
      r = std::min({std::clamp(r, min_r, max_r), border_v, std::min(u, cols - 1 - u) - reach});
      // The largest window (radius r + reach) that holds no step mark.
      r = std::min(r, dist[u] - 1 - reach);
      if (r < min_r) continue;
      const int w = 2 * r + 1;
      const float area = static_cast<float>(w * w);
      auto count = [&](int uc, int vc) {
        const std::uint32_t* a = Mi + (vc - r) * mstride + (uc - r);
        return static_cast<int>(rectU32(a, a + w, a + w * mstride, a + w * (mstride + 1)));
      };

      float nx, ny, nz;
      const double n = count(u, v);
      if (n < std::max(6.0f, min_frac * area)) continue;
      const double* a = integral_.data() + (v - r) * stride + (u - r) * K;
      const double* b = a + w * K;
      const double* c = a + w * stride;
      const double* d = c + w * K;
      double m[K];  // window sums of the moments
      for (int k = 0; k < K; ++k) m[k] = d[k] - b[k] - c[k] + a[k];
      const double inv = 1.0 / n;
      const double mx = m[0] * inv, my = m[1] * inv, mz = m[2] * inv;
      const double cxx = m[3] * inv - mx * mx, cxy = m[4] * inv - mx * my,
                   cxz = m[5] * inv - mx * mz;
      const double cyy = m[6] * inv - my * my, cyz = m[7] * inv - my * mz,
                   czz = m[8] * inv - mz * mz;
      // Smallest eigenvector of C = dominant eigenvector of adj(C) (eigenvalues l2*l3, l1*l3,
      // l1*l2): power iteration converges with ratio l1/l2, i.e. in one or two steps on a
      // planar patch. Start from the viewing ray (visible surfaces face the camera).
      const double a00 = cyy * czz - cyz * cyz, a01 = cxz * cyz - cxy * czz,
                   a02 = cxy * cyz - cxz * cyy;
      const double a11 = cxx * czz - cxz * cxz, a12 = cxy * cxz - cxx * cyz,
                   a22 = cxx * cyy - cxy * cxy;
      // The iterates are normalised once at the end (a direction is all that is needed, and the
      // range of double covers three products by adj(C)), not at every step.
      double ex = -mx, ey = -my, ez = -mz;
      for (int it = 0; it < 3; ++it) {
        const double tx = a00 * ex + a01 * ey + a02 * ez;
        const double ty = a01 * ex + a11 * ey + a12 * ez;
        const double tz = a02 * ex + a12 * ey + a22 * ez;
        if (!(tx * tx + ty * ty + tz * tz > 0.0)) break;
        ex = tx;
        ey = ty;
        ez = tz;
      }
      const double inv_len = 1.0 / std::sqrt(ex * ex + ey * ey + ez * ez);
      nx = static_cast<float>(ex * inv_len);
      ny = static_cast<float>(ey * inv_len);
      nz = static_cast<float>(ez * inv_len);
      const float len2 = nx * nx + ny * ny + nz * nz;
      if (!(len2 > 1e-20f)) continue;
      float s = 1.0f / std::sqrt(len2);
      if (nx * p[u][0] + ny * p[u][1] + nz * z > 0.0f) s = -s;  // face the camera
      n_out[u] = cv::Vec3f(nx * s, ny * s, nz * s);
    }
  }
}

// The gradient modes: one packed integral image (valid count and the 0.1 mm sums), read with one
// load per corner: 4 uint32 lanes (X, Y, Z, count) for the 3D gradient, one uint64 (count in the
// low half, Z in the high half) for the depth change. All sums wrap around; window sums are exact
// because no field of a window sum overflows. Depth steps bound the radius through stepDistance().
template <int M>
void NormalEstimator::runGradient(const CameraIntrinsics& intr, cv::Mat& normals) {
  const int rows = rows_, cols = cols_;
  const std::size_t estride = static_cast<std::size_t>(cols + 1);
  constexpr int L = M == kGrad ? 4 : 2;  // uint32 per element
  constexpr int K = M == kGrad ? 4 : 2;  // floats per cached window: means, then the count
  const std::size_t rstride = estride * L;
  // The windows of row v read integral rows v - max_r - 1 to v + max_r + 2 only, so the integral
  // image lives in a ring of that many rows (~0.45 MB at the default max_r instead of ~5 MB): it
  // stays in L2 instead of going to memory and back. Integral row y is in slot y % ring_rows.
  const int min_r = std::max(1, params_.min_radius_px);
  const int max_r = std::max(min_r, params_.max_radius_px);
  const int ring_rows = std::min(rows + 1, 2 * max_r + 4);
  // + 4: the depth-change mode reads a 16-byte pair of 8-byte elements for the last one of the
  // last ring row (the second half is discarded).
  packed_.resize(static_cast<std::size_t>(ring_rows) * rstride + 4);
  integral_rows_.resize(static_cast<std::size_t>(rows) + 1);
  for (int y = 0; y <= rows; ++y)
    integral_rows_[y] = packed_.data() + static_cast<std::size_t>(y % ring_rows) * rstride;
  std::uint32_t* const* irow = integral_rows_.data();
  std::fill(irow[0], irow[0] + rstride, 0u);
  // AVX2 steps where the CPU has them (tests: setAvx2(false), setSimd(false)).
  [[maybe_unused]] bool use_avx2 = false;
#if defined(SHAPESENSE_AVX2_PATHS)
  use_avx2 = simd_ && avx2_ && cpuHasAvx2();
#endif
  // Integral row v + 1 from image row v. Built lazily, just ahead of the rows pass 1 reads, so that
  // the rows it reads are still in cache.
  auto buildRow = [&](int v) __attribute__((always_inline)) {
    std::uint32_t* row = irow[v + 1];
    const std::uint32_t* above = irow[v];
    if constexpr (M == kGrad) {
      // Point-cloud input: the points' row; depth input: none (the points are z times the rays,
      // rebuilt here from the z plane with the products buildPoints() uses, so the same values).
      const float* pf = points_from_depth_ ? nullptr : points_.ptr<float>(v);
      const float* zrow = zplane_.data() + static_cast<std::size_t>(v) * cols;
      const float* rx = ray_x_.data();
      const float ry_v = points_from_depth_ ? ray_y_[v] : 0.0f;
      // (x, y, z, -) of pixel `col` of this row.
      auto point = [&](int col) {
        v4f xyz = {0.0f, 0.0f, 0.0f, 0.0f};
        if (points_from_depth_) {
          const float z = zrow[col];
          xyz = v4f{rx[col] * z, ry_v * z, z, 0.0f};
        } else {
          std::memcpy(&xyz, pf + 3 * col, 3 * sizeof(float));
        }
        return xyz;
      };
      int u = 0;
#if defined(__SSE2__)
      // Branch-free (holes are frequent and irregular): the validity mask of z zeroes the
      // invalid point's lanes and gives the count lane; same values as the scalar loop below.
      const __m128 scale = _mm_set1_ps(1e4f), zero = _mm_setzero_ps();
      const __m128i xyz_lanes = _mm_set_epi32(0, -1, -1, -1), count_one = _mm_set_epi32(1, 0, 0, 0);
      __m128i acc = _mm_setzero_si128();
      _mm_storeu_si128(reinterpret_cast<__m128i*>(row), acc);
      if (points_from_depth_) {
        // The points are z times the pixel rays: rebuilt from the z plane and the rays (the same
        // products as in compute(), so the same values), four pixels at a time, reading 4 bytes
        // per pixel from memory instead of 12.
        const __m128 ry = _mm_set1_ps(ry_v);
        const __m128i one = _mm_set1_epi32(1);
#if defined(SHAPESENSE_AVX2_PATHS)
        if (use_avx2) u = gradIntegralRowAvx2(zrow, rx, ry_v, above, row, cols, acc);
#endif
        for (; u + 4 < cols; u += 4) {  // the row's last pixel is left to element() below
          const __m128 z = _mm_loadu_ps(zrow + u);
          const __m128i ok = _mm_castps_si128(_mm_cmpgt_ps(z, zero));
          auto toFixed = [&](__m128 c) {
            return _mm_and_si128(_mm_cvttps_epi32(_mm_mul_ps(c, scale)), ok);
          };
          const __m128i fx = toFixed(_mm_mul_ps(_mm_loadu_ps(rx + u), z));
          const __m128i fy = toFixed(_mm_mul_ps(ry, z)), fz = toFixed(z);
          const __m128i count = _mm_and_si128(ok, one);
          // Transpose the (x, y, z, count) planes to one element per pixel.
          const __m128i xy01 = _mm_unpacklo_epi32(fx, fy), zc01 = _mm_unpacklo_epi32(fz, count);
          const __m128i xy23 = _mm_unpackhi_epi32(fx, fy), zc23 = _mm_unpackhi_epi32(fz, count);
          const __m128i e[4] = {_mm_unpacklo_epi64(xy01, zc01), _mm_unpackhi_epi64(xy01, zc01),
                                _mm_unpacklo_epi64(xy23, zc23), _mm_unpackhi_epi64(xy23, zc23)};
          for (int k = 0; k < 4; ++k) {
            acc = _mm_add_epi32(acc, e[k]);
            const auto* up = reinterpret_cast<const __m128i*>(above + (u + k + 1) * 4);
            _mm_storeu_si128(reinterpret_cast<__m128i*>(row + (u + k + 1) * 4),
                             _mm_add_epi32(_mm_loadu_si128(up), acc));
          }
        }
      }
      // A 16-byte load per pixel reads the next pixel's x too: stop one pixel short of the end.
      for (; !points_from_depth_ && u + 1 < cols; ++u) {
        const __m128 xyz = _mm_loadu_ps(pf + 3 * u);
        const __m128i ok =
            _mm_castps_si128(_mm_cmpgt_ps(_mm_shuffle_ps(xyz, xyz, _MM_SHUFFLE(2, 2, 2, 2)), zero));
        const __m128i fixed_xyz = _mm_cvttps_epi32(_mm_mul_ps(xyz, scale));
        const __m128i e = _mm_or_si128(_mm_and_si128(fixed_xyz, _mm_and_si128(ok, xyz_lanes)),
                                       _mm_and_si128(ok, count_one));
        acc = _mm_add_epi32(acc, e);
        const auto* up = reinterpret_cast<const __m128i*>(above + (u + 1) * 4);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(row + (u + 1) * 4),
                         _mm_add_epi32(_mm_loadu_si128(up), acc));
      }
      v4u acc_v;
      std::memcpy(&acc_v, &acc, sizeof acc_v);
#else
      v4u acc_v = {0, 0, 0, 0};
      store4(row, acc_v);
#endif
      // One pixel's element from its (x, y, z, -).
      auto element = [&](int col, v4f xyz) {
        const bool ok = validZ(xyz[2]);
        const v4f kept = ok ? xyz * 1e4f : v4f{0.0f, 0.0f, 0.0f, 0.0f};
        v4u e = reinterpret_cast<v4u>(__builtin_convertvector(kept, v4i));
        e[3] = static_cast<std::uint32_t>(ok);
        acc_v += e;
        store4(row + (col + 1) * 4, load4(above + (col + 1) * 4) + acc_v);
      };
      for (; u < cols; ++u) element(u, point(u));
    } else {
      auto* row64 = reinterpret_cast<std::uint64_t*>(row);
      const auto* above64 = reinterpret_cast<const std::uint64_t*>(above);
      const float* zrow = zplane_.data() + static_cast<std::size_t>(v) * cols;
      std::uint64_t acc = 0;
      row64[0] = 0;
      int u = 0;
#if defined(__SSE2__)
      // Four pixels at a time and branch-free (holes are frequent and irregular): (count, fixed
      // z) pairs interleaved into uint64 lanes, prefix-summed within each pair of lanes; same
      // values as the scalar loop below.
      const __m128 scale = _mm_set1_ps(1e4f), zero = _mm_setzero_ps();
      const __m128i one = _mm_set1_epi32(1);
      __m128i acc2 = _mm_setzero_si128();  // the running sum in both lanes
      for (; u + 4 <= cols; u += 4) {
        const __m128 z = _mm_loadu_ps(zrow + u);
        const __m128i ok = _mm_castps_si128(_mm_cmpgt_ps(z, zero));
        const __m128i fixed_z = _mm_and_si128(_mm_cvttps_epi32(_mm_mul_ps(z, scale)), ok);
        const __m128i count = _mm_and_si128(ok, one);
        __m128i e01 = _mm_unpacklo_epi32(count, fixed_z), e23 = _mm_unpackhi_epi32(count, fixed_z);
        e01 = _mm_add_epi64(_mm_add_epi64(e01, _mm_slli_si128(e01, 8)), acc2);
        acc2 = _mm_unpackhi_epi64(e01, e01);
        e23 = _mm_add_epi64(_mm_add_epi64(e23, _mm_slli_si128(e23, 8)), acc2);
        acc2 = _mm_unpackhi_epi64(e23, e23);
        const auto* up = reinterpret_cast<const __m128i*>(above64 + u + 1);
        auto* out = reinterpret_cast<__m128i*>(row64 + u + 1);
        _mm_storeu_si128(out, _mm_add_epi64(_mm_loadu_si128(up), e01));
        _mm_storeu_si128(out + 1, _mm_add_epi64(_mm_loadu_si128(up + 1), e23));
      }
      std::memcpy(&acc, &acc2, sizeof acc);
#endif
      for (; u < cols; ++u) {
        const float z = zrow[u];
        const bool ok = validZ(z);
        acc += static_cast<std::uint64_t>(ok) + (static_cast<std::uint64_t>(fixed(z, ok)) << 32);
        row64[u + 1] = above64[u + 1] + acc;
      }
    }
  };

  const float base_r = static_cast<float>(params_.smoothing_radius_px) *
                       (params_.depth_dependent_smoothing ? 1.0f : 0.0f);
  const float const_r =
      params_.depth_dependent_smoothing ? 0.0f : static_cast<float>(params_.smoothing_radius_px);
  const float min_frac = static_cast<float>(params_.min_valid_fraction);
  const float fx = static_cast<float>(intr.fx), fy = static_cast<float>(intr.fy);
  const float cx = static_cast<float>(intr.cx), cy = static_cast<float>(intr.cy);

  // Per row: (a) the window radius of every pixel (branch-free), (b) per pixel the step check
  // and the four windows centred one pixel left/right/up/down (one packed fetch per corner),
  // giving the unnormalised normal (0 where invalid), (c) normalisation (SIMD; fused into (b)
  // where (b) runs four pixels at a time).
  rad_.resize(static_cast<std::size_t>(cols));
  row_n_.resize(3 * static_cast<std::size_t>(cols));
  int* rr = rad_.data();
  float* rnx = row_n_.data();
  float* rny = rnx + cols;
  float* rnz = rny + cols;
  const float ifx = 1.0f / fx, ify = 1.0f / fy;
  // 1 / count by table lookup: the same value as the division, without a division per window.
  const std::size_t max_count =
      static_cast<std::size_t>(2 * max_r + 1) * static_cast<std::size_t>(2 * max_r + 1);
  if (inv_count_.size() != max_count + 1) {
    inv_count_.resize(max_count + 1);
    inv_count_[0] = 0.0f;
    for (std::size_t n = 1; n <= max_count; ++n) inv_count_[n] = 1.0f / static_cast<float>(n);
  }
  const float min_rf = static_cast<float>(min_r), max_rf = static_cast<float>(max_r);
  // Largest r that the image width leaves at each column (reach r + 1).
  col_bound_.resize(static_cast<std::size_t>(cols));
  for (int u = 0; u < cols; ++u) col_bound_[u] = static_cast<float>(std::min(u, cols - 1 - u) - 1);
  const float* colb = col_bound_.data();
  // Fewest valid pixels a window of each radius needs.
  min_count_.resize(static_cast<std::size_t>(max_r) + 1);
  for (int r = 0; r <= max_r; ++r) {
    min_count_[r] =
        std::max(4, static_cast<int>(min_frac * static_cast<float>((2 * r + 1) * (2 * r + 1))));
  }
  const int* min_count = min_count_.data();
  stepDistance(std::min(max_r + 3, 30000));  // any cap above max_r + 2 is "far"
  win_mean_.resize(3 * static_cast<std::size_t>(cols) * K);
  win_radius_.assign(3 * static_cast<std::size_t>(cols), 0);  // 0: nothing cached
  int built = 0;                                              // image rows integrated so far
  for (int v = 0; v < rows; ++v) {
    // The windows reach r + 1 rows below v: integral rows up to v + max_r + 2.
    for (const int need = std::min(rows, v + max_r + 2); built < need; ++built) buildRow(built);
    const float* zrow = zplane_.data() + static_cast<std::size_t>(v) * cols;
    const int border_v = std::min(v, rows - 1 - v) - 1;  // largest r inside the image (reach r + 1)
    // (a) r = 0 marks an invalid pixel (no depth, or no room). Clamped in float before the
    // truncation (same result: the bounds are integers and r >= 0) because SSE2 has no int32
    // min / max: the loop vectorises.
    // The step distance bounds r so that the union of the four windows (radius r + 1) holds no
    // step mark: r + 1 < distance.
    const float bv = static_cast<float>(border_v);
    const std::int16_t* dist = step_dist_.data() + static_cast<std::size_t>(v) * cols;
    auto radius = [&](int u) {
      const float zp = zrow[u];
      const bool ok = zp > 0.0f;
      float r = base_r * (ok ? zp : 0.0f) + const_r + 0.5f;
      r = r < min_rf ? min_rf : r;
      r = r > max_rf ? max_rf : r;
      r = r < colb[u] ? r : colb[u];
      r = r < bv ? r : bv;
      const float by_step = static_cast<float>(dist[u] - 2);
      r = r < by_step ? r : by_step;
      rr[u] = ok && r >= min_rf ? static_cast<int>(r) : 0;
    };
    // (Separate loops: a loop from a computed start does not vectorise.)
#if defined(SHAPESENSE_AVX2_PATHS)
    if (use_avx2) {
      const int u0 = radiusRowAvx2(zrow, dist, colb, cols, base_r, const_r, min_rf, max_rf, bv, rr);
      for (int u = u0; u < cols; ++u) radius(u);
    } else
#endif
    {
      for (int u = 0; u < cols; ++u) radius(u);
    }
    // (b) Every window is centred on a pixel (x, y) and is read by up to four pixels: as the
    // left/right window of (x +- 1, y), the down window of (x, y - 1) and the up window of
    // (x, y + 1). Its mean (channel K - 1: the count) is cached per centre and radius for the
    // three rows of centres in use, so that where neighbours share a radius each pixel computes
    // one new window instead of four. The cache is planar (channel c of a row of centres at
    // c * cols) so that four consecutive centres are one vector per channel. The window sums are
    // exact integers, so however and whenever a mean is computed it has the same bits.
    float* row_above = win_mean_.data() + static_cast<std::size_t>((v + 2) % 3) * cols * K;
    float* row_here = win_mean_.data() + static_cast<std::size_t>(v % 3) * cols * K;
    float* row_below = win_mean_.data() + static_cast<std::size_t>((v + 1) % 3) * cols * K;
    int* rad_above = win_radius_.data() + static_cast<std::size_t>((v + 2) % 3) * cols;
    int* rad_here = win_radius_.data() + static_cast<std::size_t>(v % 3) * cols;
    int* rad_below = win_radius_.data() + static_cast<std::size_t>((v + 1) % 3) * cols;
    std::fill(rad_below, rad_below + cols, 0);  // it held the centres of row v - 2
    const float* inv = inv_count_.data();
    // Caches the mean of the window of radius r centred on column x of a row of centres whose
    // row is y (computed on a miss).
    auto window = [&](float* means, int* radii, int x, int y, int r) {
      if (radii[x] == r) return;
      radii[x] = r;
      const std::ptrdiff_t dh = (2 * r + 1) * L;
      const std::uint32_t* a = irow[y - r] + (x - r) * L;      // top left
      const std::uint32_t* c = irow[y + r + 1] + (x - r) * L;  // bottom left
      if constexpr (M == kGrad) {
        const v4u s = load4(c + dh) - load4(a + dh) - load4(c) + load4(a);
        const int n = static_cast<int>(s[3]);
        const v4f m = __builtin_convertvector(reinterpret_cast<const v4i&>(s), v4f) * inv[n];
        for (int k = 0; k < 3; ++k) means[k * cols + x] = m[k];
        means[3 * cols + x] = static_cast<float>(n);
      } else {
        auto corner = [](const std::uint32_t* c) {
          std::uint64_t x64;
          std::memcpy(&x64, c, sizeof x64);
          return x64;
        };
        const std::uint64_t s = corner(c + dh) - corner(a + dh) - corner(c) + corner(a);
        const auto n = static_cast<std::uint32_t>(s);
        means[x] = static_cast<float>(static_cast<std::int32_t>(s >> 32)) * inv[n];
        means[cols + x] = static_cast<float>(n);
      }
    };
    // One pixel: the unnormalised normal, 0 where invalid.
    auto pixel = [&](int u) {
      const int r = rr[u];
      rnx[u] = rny[u] = rnz[u] = 0.0f;
      if (r == 0) return;
      window(row_here, rad_here, u - 1, v, r);
      window(row_here, rad_here, u + 1, v, r);
      window(row_above, rad_above, u, v - 1, r);
      window(row_below, rad_below, u, v + 1, r);
      // Channel k of the left, right, up and down windows.
      auto l = [&](int k) { return row_here[k * cols + u - 1]; };
      auto rt = [&](int k) { return row_here[k * cols + u + 1]; };
      auto up = [&](int k) { return row_above[k * cols + u]; };
      auto dn = [&](int k) { return row_below[k * cols + u]; };
      const float min_n = static_cast<float>(min_count[r]);
      if (std::min(std::min(l(K - 1), rt(K - 1)), std::min(up(K - 1), dn(K - 1))) < min_n) return;
      if constexpr (M == kGrad) {
        // Differences of the means of the four windows: the averaged tangents (for a plane the
        // mean of 3D points lies on the plane); the normal is h x t.
        const float hx = rt(0) - l(0), hy = rt(1) - l(1), hz = rt(2) - l(2);
        const float tx = dn(0) - up(0), ty = dn(1) - up(1), tz = dn(2) - up(2);
        rnx[u] = hy * tz - hz * ty;
        rny[u] = hz * tx - hx * tz;
        rnz[u] = hx * ty - hy * tx;
      } else {
        const float zl = l(0), zr = rt(0), zu_ = up(0), zd = dn(0);
        // Depth derivatives per pixel and the pinhole model: for z(u, v) the (unnormalised)
        // normal facing the camera is (fx zu, fy zv, -(z + (u-cx) zu + (v-cy) zv)).
        const float du = 0.5f * (zr - zl), dv = 0.5f * (zd - zu_);
        const float zm = 0.25f * (zl + zr + zu_ + zd);
        rnx[u] = fx * du;
        rny[u] = fy * dv;
        rnz[u] = -(zm + (static_cast<float>(u) - cx) * du + (static_cast<float>(v) - cy) * dv);
      }
    };
    // (c)'s inputs: the ray y of this row, the output row.
    const float ry = (static_cast<float>(v) - cy) * ify;
    float* out = normals.ptr<float>(v);
    int u = 0;
#if defined(__SSE2__)
    // Four pixels at a time where the valid ones share one radius r (the radius follows the depth
    // slowly, so this is most of the image): the windows of four consecutive centres are computed
    // together (one 4x4 transpose of the corner differences) and the normals with the same
    // operations, in the same order, as pixel() - the same bits. Invalid lanes (r = 0) ride along
    // when their windows stay inside the image and are zeroed at the end; anything else goes to
    // pixel().
    if (simd_) {
      // The windows of radius r of centres x..x+3 of the row of centres y, into the cache.
      auto quad = [&](float* means, int* radii, int x, int y, int r) {
        _mm_storeu_si128(reinterpret_cast<__m128i*>(radii + x), _mm_set1_epi32(r));
        const std::ptrdiff_t dh = (2 * r + 1) * L;
        const std::uint32_t* a = irow[y - r] + (x - r) * L;
        const std::uint32_t* c = irow[y + r + 1] + (x - r) * L;
        auto ld = [](const std::uint32_t* p) {
          return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
        };
        auto sum = [&](int off) {
          return _mm_add_epi32(
              _mm_sub_epi32(_mm_sub_epi32(ld(c + dh + off), ld(a + dh + off)), ld(c + off)),
              ld(a + off));
        };
        __m128i count;
        __m128 chan[3];
        if constexpr (M == kGrad) {
          const __m128i s0 = sum(0), s1 = sum(4), s2 = sum(8), s3 = sum(12);  // (X, Y, Z, n)
          const __m128i t0 = _mm_unpacklo_epi32(s0, s1), t1 = _mm_unpacklo_epi32(s2, s3);
          const __m128i t2 = _mm_unpackhi_epi32(s0, s1), t3 = _mm_unpackhi_epi32(s2, s3);
          chan[0] = _mm_cvtepi32_ps(_mm_unpacklo_epi64(t0, t1));
          chan[1] = _mm_cvtepi32_ps(_mm_unpackhi_epi64(t0, t1));
          chan[2] = _mm_cvtepi32_ps(_mm_unpacklo_epi64(t2, t3));
          count = _mm_unpackhi_epi64(t2, t3);
        } else {
          // (n, Z) uint32 pairs: as exact as the uint64 difference (the counts never borrow).
          const __m128 s01 = _mm_castsi128_ps(sum(0)), s23 = _mm_castsi128_ps(sum(4));
          chan[0] =
              _mm_cvtepi32_ps(_mm_castps_si128(_mm_shuffle_ps(s01, s23, _MM_SHUFFLE(3, 1, 3, 1))));
          count = _mm_castps_si128(_mm_shuffle_ps(s01, s23, _MM_SHUFFLE(2, 0, 2, 0)));
        }
        const __m128 nf = _mm_cvtepi32_ps(count);
        // 1 / n, correctly rounded like the table, and 0 for n = 0 like the table.
        const __m128 inv_n =
            _mm_and_ps(_mm_div_ps(_mm_set1_ps(1.0f), nf), _mm_cmpgt_ps(nf, _mm_setzero_ps()));
        for (int k = 0; k < K - 1; ++k)
          _mm_storeu_ps(means + k * cols + x, _mm_mul_ps(chan[k], inv_n));
        _mm_storeu_ps(means + (K - 1) * cols + x, nf);
      };
      auto ensure = [&](float* means, int* radii, int x, int y, __m128i rv, int r) {
        const __m128i have = _mm_loadu_si128(reinterpret_cast<const __m128i*>(radii + x));
        if (_mm_movemask_epi8(_mm_cmpeq_epi32(have, rv)) != 0xFFFF) quad(means, radii, x, y, r);
      };
      const __m128 lane = _mm_set_ps(3.0f, 2.0f, 1.0f, 0.0f);
      const __m128 half = _mm_set1_ps(0.5f), quarter = _mm_set1_ps(0.25f);
      const __m128 vfx = _mm_set1_ps(fx), vfy = _mm_set1_ps(fy), vcx = _mm_set1_ps(cx);
      const __m128 vdy = _mm_set1_ps(static_cast<float>(v) - cy);
      // The normals of the lanes of pixels u..u+3 whose radius is r (rv: r in every lane; the
      // other lanes come out 0).
      auto four = [&](int u, int r, __m128i rv, __m128i lanes, __m128& nx, __m128& ny, __m128& nz)
          __attribute__((always_inline)) {
        ensure(row_here, rad_here, u - 1, v, rv, r);
        ensure(row_here, rad_here, u + 1, v, rv, r);
        ensure(row_above, rad_above, u, v - 1, rv, r);
        ensure(row_below, rad_below, u, v + 1, rv, r);
        auto l = [&](int k) { return _mm_loadu_ps(row_here + k * cols + u - 1); };
        auto rt = [&](int k) { return _mm_loadu_ps(row_here + k * cols + u + 1); };
        auto up = [&](int k) { return _mm_loadu_ps(row_above + k * cols + u); };
        auto dn = [&](int k) { return _mm_loadu_ps(row_below + k * cols + u); };
        const __m128 nmin =
            _mm_min_ps(_mm_min_ps(l(K - 1), rt(K - 1)), _mm_min_ps(up(K - 1), dn(K - 1)));
        const __m128 ok =
            _mm_and_ps(_mm_castsi128_ps(lanes),
                       _mm_cmpge_ps(nmin, _mm_set1_ps(static_cast<float>(min_count[r]))));
        if constexpr (M == kGrad) {
          const __m128 hx = _mm_sub_ps(rt(0), l(0)), hy = _mm_sub_ps(rt(1), l(1)),
                       hz = _mm_sub_ps(rt(2), l(2));
          const __m128 tx = _mm_sub_ps(dn(0), up(0)), ty = _mm_sub_ps(dn(1), up(1)),
                       tz = _mm_sub_ps(dn(2), up(2));
          nx = _mm_sub_ps(_mm_mul_ps(hy, tz), _mm_mul_ps(hz, ty));
          ny = _mm_sub_ps(_mm_mul_ps(hz, tx), _mm_mul_ps(hx, tz));
          nz = _mm_sub_ps(_mm_mul_ps(hx, ty), _mm_mul_ps(hy, tx));
        } else {
          const __m128 zl = l(0), zr = rt(0), zu_ = up(0), zd = dn(0);
          const __m128 du = _mm_mul_ps(half, _mm_sub_ps(zr, zl));
          const __m128 dv = _mm_mul_ps(half, _mm_sub_ps(zd, zu_));
          const __m128 zm =
              _mm_mul_ps(quarter, _mm_add_ps(_mm_add_ps(_mm_add_ps(zl, zr), zu_), zd));
          const __m128 dx = _mm_sub_ps(_mm_add_ps(_mm_set1_ps(static_cast<float>(u)), lane), vcx);
          nx = _mm_mul_ps(vfx, du);
          ny = _mm_mul_ps(vfy, dv);
          nz = _mm_xor_ps(_mm_set1_ps(-0.0f),
                          _mm_add_ps(_mm_add_ps(zm, _mm_mul_ps(dx, du)), _mm_mul_ps(vdy, dv)));
        }
        nx = _mm_and_ps(ok, nx);
        ny = _mm_and_ps(ok, ny);
        nz = _mm_and_ps(ok, nz);
      };
      const RowWindows g{row_above, row_here, row_below, rad_above, rad_here, rad_below,
                         irow,      rr,       min_count, cols,      v,        fx,
                         fy,        cx,       cy,        ifx,       ry,       out};
      // Pixels u..u+3.
      auto group4 = [&](int u) __attribute__((always_inline)) {
        const __m128i rv4 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(rr + u));
        const __m128i invalid = _mm_cmpeq_epi32(rv4, _mm_setzero_si128());
        const int valid_lanes = ~_mm_movemask_ps(_mm_castsi128_ps(invalid)) & 15;
        if (valid_lanes == 0) {
          for (int k = 0; k < 3; ++k) _mm_storeu_ps(out + 3 * u + 4 * k, _mm_set1_ps(kNaN));
          return;
        }
        const int r = rr[u + __builtin_ctz(static_cast<unsigned>(valid_lanes))];
        const __m128i rv = _mm_set1_epi32(r);
        const __m128i lanes = _mm_cmpeq_epi32(rv4, rv);
        // The windows of centres u - 1 .. u + 4 must lie inside the image: a valid pixel's windows
        // do (its radius is bounded by the border), invalid lanes ride along with radius r (rows:
        // r is a valid pixel's radius, so it fits this row).
        if (u - 1 - r < 0 || u + 5 + r > cols) {
          for (int k = 0; k < 4; ++k) pixel(u + k);
          normalize4(_mm_loadu_ps(rnx + u), _mm_loadu_ps(rny + u), _mm_loadu_ps(rnz + u), u, cx,
                     ifx, ry, out);
          return;
        }
        __m128 nx, ny, nz;
        if ((valid_lanes & ~_mm_movemask_ps(_mm_castsi128_ps(lanes))) == 0) {
          four(u, r, rv, lanes, nx, ny, nz);
        } else {
          // The valid lanes' radii differ: each lane its own radius (invalid lanes r).
          const __m128i rl =
              _mm_or_si128(_mm_andnot_si128(invalid, rv4), _mm_and_si128(invalid, rv));
          fourLanes<M>(g, u, rl, _mm_xor_si128(invalid, _mm_set1_epi32(-1)), nx, ny, nz);
        }
        normalize4(nx, ny, nz, u, cx, ifx, ry, out);  // (c), fused: no round trip through rnx
      };
      // Eight pixels per AVX2 step (3D gradient, where the CPU has AVX2) where their valid lanes
      // share one radius and the windows of centres u - 1 .. u + 8 lie inside the image; four
      // pixels per step elsewhere.
      [[maybe_unused]] bool eight = false;
#if defined(SHAPESENSE_AVX2_PATHS)
      eight = M == kGrad && use_avx2;
#endif
      while (u + 4 <= cols) {
#if defined(SHAPESENSE_AVX2_PATHS)
        if (eight) {
          u = gradRun(g, u);
          if (u + 4 > cols) break;
        }
#endif
        group4(u);
        u += 4;
      }
    }
#endif
    const int u_tail = u;  // (c) is done up to here
    for (; u < cols; ++u) pixel(u);
    // (c) of the pixels (b) did one at a time at the end of the row (all of it without SIMD).
    normalizeRow(rnx, rny, rnz, cx, ifx, ry, u_tail, cols, out);
  }
}

void NormalEstimator::buildPoints() {
  if (!points_from_depth_ || points_built_) return;
  points_built_ = true;
  const int rows = rows_, cols = cols_;
  points_.create(rows, cols, CV_32FC3);
  const float* rx = ray_x_.data();
  for (int v = 0; v < rows; ++v) {
    float* p = points_.ptr<float>(v);
    const float ry = ray_y_[v];
    const float* zr = zplane_.data() + static_cast<std::size_t>(v) * cols;
    int u = 0;
#if defined(__SSE2__)
    // Same arithmetic as the loop below, four pixels at a time: the compiler vectorises that
    // loop's arithmetic but not its interleaved stores.
    const __m128 vry = _mm_set1_ps(ry);
    for (; u + 4 <= cols; u += 4) {
      const __m128 z = _mm_loadu_ps(zr + u);
      storeInterleaved(_mm_mul_ps(_mm_loadu_ps(rx + u), z), _mm_mul_ps(vry, z), z, p + 3 * u);
    }
#endif
    for (; u < cols; ++u) {
      const float z = zr[u];
      p[3 * u] = rx[u] * z;
      p[3 * u + 1] = ry * z;
      p[3 * u + 2] = z;
    }
  }
}

void NormalEstimator::compute(const cv::Mat& input, const CameraIntrinsics& intr,
                              cv::Mat& normals) {
  CV_Assert(input.type() == CV_16UC1 || input.type() == CV_32FC3);
  const int rows = input.rows, cols = input.cols;
  rows_ = rows;
  cols_ = cols;
  zplane_.resize(static_cast<std::size_t>(rows) * cols);
  if (input.type() == CV_16UC1) {
    // The points are z times the pixel rays: only the z plane and the rays are stored (the
    // gradient modes rebuild the points from them; buildPoints() makes the point image for the
    // covariance mode and points()).
    const float inv_fx = static_cast<float>(1.0 / intr.fx),
                inv_fy = static_cast<float>(1.0 / intr.fy);
    const float cx = static_cast<float>(intr.cx), cy = static_cast<float>(intr.cy);
    ray_x_.resize(static_cast<std::size_t>(cols));
    for (int u = 0; u < cols; ++u) ray_x_[u] = (static_cast<float>(u) - cx) * inv_fx;
    ray_y_.resize(static_cast<std::size_t>(rows));
    for (int v = 0; v < rows; ++v) ray_y_[v] = (static_cast<float>(v) - cy) * inv_fy;
    points_from_depth_ = true;
    points_built_ = false;
    [[maybe_unused]] bool use_avx2 = false;  // AVX2 steps where the CPU has them
#if defined(SHAPESENSE_AVX2_PATHS)
    use_avx2 = simd_ && avx2_ && cpuHasAvx2();
#endif
    for (int v = 0; v < rows; ++v) {
      const auto* d = input.ptr<std::uint16_t>(v);
      float* zr = zplane_.data() + static_cast<std::size_t>(v) * cols;
      int u = 0;
#if defined(SHAPESENSE_AVX2_PATHS)
      if (use_avx2) u = depthRowAvx2(d, zr, cols);
#endif
#if defined(__SSE2__)
      const __m128 to_metres = _mm_set1_ps(0.001f);
      const __m128 zero = _mm_setzero_ps(), nan = _mm_set1_ps(kNaN);
      for (; u + 8 <= cols; u += 8) {
        const __m128i raw = _mm_loadu_si128(reinterpret_cast<const __m128i*>(d + u));
        auto toZ = [&](__m128i mm32) {
          const __m128 metres = _mm_mul_ps(_mm_cvtepi32_ps(mm32), to_metres);
          const __m128 ok = _mm_cmpgt_ps(metres, zero);
          return _mm_or_ps(_mm_and_ps(ok, metres), _mm_andnot_ps(ok, nan));
        };
        _mm_storeu_ps(zr + u, toZ(_mm_unpacklo_epi16(raw, _mm_setzero_si128())));
        _mm_storeu_ps(zr + u + 4, toZ(_mm_unpackhi_epi16(raw, _mm_setzero_si128())));
      }
#endif
      for (; u < cols; ++u) {
        const float metres = static_cast<float>(d[u]) * 0.001f;
        zr[u] = metres > 0.0f ? metres : kNaN;
      }
    }
  } else {
    input.copyTo(points_);
    points_from_depth_ = false;
    for (int v = 0; v < rows; ++v) {
      const auto* p = points_.ptr<cv::Vec3f>(v);
      float* zr = zplane_.data() + static_cast<std::size_t>(v) * cols;
      for (int u = 0; u < cols; ++u) zr[u] = p[u][2];
    }
  }
  normals.create(rows, cols, CV_32FC3);
  if (rows == 0 || cols == 0) return;  // no pixel (the row scans assume one)
  markSteps();
  switch (params_.method) {
    case NormalMethod::kCovariance:
      normals.setTo(cv::Scalar::all(kNaN));
      runCovariance(normals);
      break;
    case NormalMethod::kAverage3dGradient:
      runGradient<kGrad>(intr, normals);
      break;
    case NormalMethod::kAverageDepthChange:
      runGradient<kDepth>(intr, normals);
      break;
  }
}

cv::Mat computeNormals(const cv::Mat& points_or_depth, const CameraIntrinsics& intrinsics,
                       const NormalParams& params) {
  NormalEstimator estimator(params);
  cv::Mat normals;
  estimator.compute(points_or_depth, intrinsics, normals);
  return normals;
}

}  // namespace shapesense
