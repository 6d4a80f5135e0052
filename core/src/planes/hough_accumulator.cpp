#include "shapesense/core/planes/hough_accumulator.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numeric>
#include <tuple>
#include <type_traits>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "cpu_dispatch.h"  // SHAPESENSE_AVX2_PATHS: the AVX2 smoothing passes (GCC only)

namespace shapesense {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Normalised 1D Gaussian taps for sigma in cells, radius min(ceil(2.5 sigma), max_radius).
std::vector<float> gaussianTaps(double sigma_cells, int max_radius) {
  if (!(sigma_cells > 1e-6)) return {1.0f};
  const int r = std::min(static_cast<int>(std::ceil(2.5 * sigma_cells)), max_radius);
  std::vector<float> w(2 * r + 1);
  double sum = 0;
  for (int t = -r; t <= r; ++t) {
    const double v = std::exp(-0.5 * t * t / (sigma_cells * sigma_cells));
    w[t + r] = static_cast<float>(v);
    sum += v;
  }
  for (auto& v : w) v = static_cast<float>(v / sum);
  return w;
}

inline int cellInBlock(int li, int lj, int lk) {
  return (lk * HoughAccumulator::kBlock + lj) * HoughAccumulator::kBlock + li;
}

constexpr int kB = HoughAccumulator::kBlock;
constexpr int kTaps = 2 * kB + 1;

// Block coordinates (bi, bj, bk) of a top-level key (bi fastest) in a space nba blocks wide
// along each Lambert axis: the inverse of HoughAccumulator::blockIndex.
inline std::array<int, 3> blockCoordsOf(int key, int nba) {
  return {key % nba, (key / nba) % nba, key / (nba * nba)};
}

// The 27 blocks of a block's 3x3x3 neighbourhood (itself included) that lie in the space, as
// top-level keys, in (z, y, x) order. Blocks off the border of the space (almost all) add
// fixed key offsets.
class BlockNeighbourhood {
 public:
  BlockNeighbourhood(int nba, int nbd) : nba_(nba), nbd_(nbd) {
    for (int t = 0, dk = -1; dk <= 1; ++dk)
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) offsets_[t++] = (dk * nba + dj) * nba + di;
  }
  /// Calls f(neighbour key) in that order until f returns true; whether it did.
  template <class F>
  bool until(int key, F&& f) const {
    const auto [bi, bj, bk] = blockCoordsOf(key, nba_);
    if (bi > 0 && bj > 0 && bk > 0 && bi + 1 < nba_ && bj + 1 < nba_ && bk + 1 < nbd_) {
      for (const int offset : offsets_)
        if (f(key + offset)) return true;
      return false;
    }
    for (int z = bk - 1; z <= bk + 1; ++z)
      for (int y = bj - 1; y <= bj + 1; ++y)
        for (int x = bi - 1; x <= bi + 1; ++x)
          if (x >= 0 && y >= 0 && z >= 0 && x < nba_ && y < nba_ && z < nbd_ &&
              f((z * nba_ + y) * nba_ + x))
            return true;
    return false;
  }
  /// f(neighbour key) for each of them.
  template <class F>
  void forEach(int key, F&& f) const {
    until(key, [&](int nkey) {
      f(nkey);
      return false;
    });
  }
  /// Whether pred(neighbour key) holds for any of them (the block itself is tried first;
  /// stops at the first).
  template <class Pred>
  bool any(int key, Pred&& pred) const {
    return pred(key) || until(key, [&](int nkey) { return nkey != key && pred(nkey); });
  }

 private:
  int nba_, nbd_;
  std::array<int, 27> offsets_{};
};

// Four floats, one per lane: an SSE2 register, or an array without SSE2 (the same IEEE
// operations either way: separate multiply and add, no FMA).
#if defined(__SSE2__)
using Quad = __m128;
inline Quad quadZero() { return _mm_setzero_ps(); }
inline Quad quadSplat(float v) { return _mm_set1_ps(v); }
inline Quad quadLoad(const float* p) { return _mm_loadu_ps(p); }
inline void quadStore(float* p, Quad q) { _mm_storeu_ps(p, q); }
inline Quad quadMulAdd(Quad acc, Quad w, Quad x) { return _mm_add_ps(acc, _mm_mul_ps(w, x)); }
inline void quadTranspose(Quad (&q)[kB]) { _MM_TRANSPOSE4_PS(q[0], q[1], q[2], q[3]); }
#else
struct Quad {
  float v[4];
};
inline Quad quadZero() { return {}; }
inline Quad quadSplat(float v) { return {{v, v, v, v}}; }
inline Quad quadLoad(const float* p) {
  Quad q;
  std::copy_n(p, 4, q.v);
  return q;
}
inline void quadStore(float* p, const Quad& q) { std::copy_n(q.v, 4, p); }
inline Quad quadMulAdd(Quad acc, const Quad& w, const Quad& x) {
  for (int i = 0; i < 4; ++i) acc.v[i] += w.v[i] * x.v[i];
  return acc;
}
inline void quadTranspose(Quad (&q)[kB]) {
  for (int r = 0; r < 4; ++r)
    for (int c = r + 1; c < 4; ++c) std::swap(q[r].v[c], q[c].v[r]);
}
#endif

// Bit c set when cells[c] >= min_value (a block of kBlockCells = 64 cells): an ordered
// compare, so a NaN cell is never a candidate.
inline std::uint64_t cellsAtLeast(const float* cells, float min_value) {
  static_assert(HoughAccumulator::kBlockCells == 64);
  std::uint64_t bits = 0;
#if defined(__SSE2__)
  const __m128 m = _mm_set1_ps(min_value);
  for (int q = 0; q < 16; ++q) {
    const int mask = _mm_movemask_ps(_mm_cmpge_ps(_mm_loadu_ps(cells + 4 * q), m));
    bits |= static_cast<std::uint64_t>(mask) << (4 * q);
  }
#else
  for (int c = 0; c < 64; ++c) bits |= static_cast<std::uint64_t>(cells[c] >= min_value) << c;
#endif
  return bits;
}

// Bit c set when a direct neighbour of cell c inside the block rules it out as a findMaxima
// maximum: a larger one, or an equal one that comes earlier in (k, j, i) order (the plateau
// tie-break). Only neighbours inside the window count: along x and y with `lambert` (window_a
// >= 1), along z with `depth` (window_d >= 1). Exact whatever the order of the tests, so it
// only saves look-ups; without SSE2 it rules nothing out.
inline std::uint64_t cellsBeatenInBlock(const float* cells, bool lambert, bool depth) {
  std::uint64_t bits = 0;
#if defined(__SSE2__)
  // Rows of 4 x-cells: row q = k * 4 + j.
  __m128 row[kB * kB];
  for (int q = 0; q < kB * kB; ++q) row[q] = _mm_loadu_ps(cells + kB * q);
  // x - 1 / x + 1 of each lane (lane 0 / lane 3 has none: masked).
  const __m128 has_prev = _mm_castsi128_ps(_mm_set_epi32(-1, -1, -1, 0));
  const __m128 has_next = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
  for (int q = 0; q < kB * kB; ++q) {
    const int j = q % kB, k = q / kB;
    const __m128 v = row[q];
    const __m128i vi = _mm_castps_si128(v);
    const __m128 prev = _mm_castsi128_ps(_mm_slli_si128(vi, 4));  // lane i: cell i - 1
    const __m128 next = _mm_castsi128_ps(_mm_srli_si128(vi, 4));  // lane i: cell i + 1
    __m128 beaten = _mm_setzero_ps();
    if (lambert) {
      beaten = _mm_or_ps(_mm_and_ps(has_prev, _mm_cmpge_ps(prev, v)),
                         _mm_and_ps(has_next, _mm_cmpgt_ps(next, v)));
      if (j > 0) beaten = _mm_or_ps(beaten, _mm_cmpge_ps(row[q - 1], v));
      if (j + 1 < kB) beaten = _mm_or_ps(beaten, _mm_cmpgt_ps(row[q + 1], v));
    }
    if (depth) {
      if (k > 0) beaten = _mm_or_ps(beaten, _mm_cmpge_ps(row[q - kB], v));
      if (k + 1 < kB) beaten = _mm_or_ps(beaten, _mm_cmpgt_ps(row[q + kB], v));
    }
    bits |= static_cast<std::uint64_t>(_mm_movemask_ps(beaten)) << (kB * q);
  }
#else
  (void)cells, (void)lambert, (void)depth;
#endif
  return bits;
}

// One output block of a smoothing pass, four independent lines at once (the lanes):
// out[t] = sum over u in [-kB, kB], ascending, of w[u + kB] * in[kB + t + u], from 0, where
// in[g] = row(g / kB, g % kB) is row g % kB of the previous (0), own (1) or next (2) block
// along the axis. Each row is loaded once and added to the outputs it reaches; every output
// still receives its terms in ascending u. Blocks that are absent or known to be zero
// (present[s] false) are skipped: their terms are exact zeros, so the sums keep their bits.
template <class Row>
[[gnu::always_inline]] inline void convolveRows(const bool (&present)[3], const Row& row,
                                                const Quad (&w)[kTaps], Quad (&out)[kB]) {
#pragma GCC unroll 4
  for (int t = 0; t < kB; ++t) out[t] = quadZero();
#pragma GCC unroll 3
  for (int s = 0; s < 3; ++s) {
    if (!present[s]) continue;
#pragma GCC unroll 4
    for (int r = 0; r < kB; ++r) {
      const Quad x = row(s, r);
#pragma GCC unroll 4
      for (int t = 0; t < kB; ++t) {
        const int u = s * kB + r - kB - t;  // the tap of in[s kB + r] for output t
        if (u >= -kB && u <= kB) out[t] = quadMulAdd(out[t], w[u + kB], x);
      }
    }
  }
}

// The y (kAlong = kB) or z (kAlong = kB^2) pass of one output block o from its previous, own
// and next source blocks along the axis: for each position p of the other axis, the 4 lines
// that differ only in x at once.
template <int kAlong>
void smoothBlockAlong(const float* const (&blocks)[3], const bool (&present)[3],
                      const Quad (&w)[kTaps], float* o) {
  constexpr int kAcross = kAlong == kB ? kB * kB : kB;  // stride of the other axis
  for (int p = 0; p < kB; ++p) {
    Quad acc[kB];
    convolveRows(
        present, [&](int s, int r) { return quadLoad(blocks[s] + p * kAcross + r * kAlong); }, w,
        acc);
    for (int t = 0; t < kB; ++t) quadStore(o + p * kAcross + t * kAlong, acc[t]);
  }
}

// The x pass of one output block o: a block line's 4 cells are contiguous, so the 4 lines of
// one z (the 4 y) are loaded and transposed, each register then holding one x position of four
// lines; the results are transposed back.
void smoothBlockX(const float* const (&blocks)[3], const bool (&present)[3], const Quad (&w)[kTaps],
                  float* o) {
  for (int k = 0; k < kB; ++k) {
    const int plane = k * kB * kB;
    Quad in[3][kB];
    for (int s = 0; s < 3; ++s) {
      if (!present[s]) continue;
      for (int j = 0; j < kB; ++j) in[s][j] = quadLoad(blocks[s] + plane + j * kB);
      quadTranspose(in[s]);
    }
    Quad acc[kB];
    convolveRows(
        present, [&](int s, int r) { return in[s][r]; }, w, acc);
    quadTranspose(acc);
    for (int j = 0; j < kB; ++j) quadStore(o + plane + j * kB, acc[j]);
  }
}

#if defined(SHAPESENSE_AVX2_PATHS)
#pragma GCC push_options
#pragma GCC target("avx2")  // no FMA contraction: the build has -ffp-contract=off

// convolveRows with eight lanes: positions p and p + 1 of the other axis in one register,
// lane for lane the same operations (the same bits).
template <class Row>
[[gnu::always_inline]] inline void convolveRows8(const bool (&present)[3], const Row& row,
                                                 const __m256 (&w)[kTaps], __m256 (&out)[kB]) {
#pragma GCC unroll 4
  for (int t = 0; t < kB; ++t) out[t] = _mm256_setzero_ps();
#pragma GCC unroll 3
  for (int s = 0; s < 3; ++s) {
    if (!present[s]) continue;
#pragma GCC unroll 4
    for (int r = 0; r < kB; ++r) {
      const __m256 x = row(s, r);
#pragma GCC unroll 4
      for (int t = 0; t < kB; ++t) {
        const int u = s * kB + r - kB - t;
        if (u >= -kB && u <= kB) out[t] = _mm256_add_ps(out[t], _mm256_mul_ps(w[u + kB], x));
      }
    }
  }
}

// smoothBlockAlong, two positions of the other axis per register (contiguous along z's other
// axis y; two halves along y's other axis z).
template <int kAlong>
void smoothBlockAlongAvx2(const float* const (&blocks)[3], const bool (&present)[3],
                          const float* taps, float* o) {
  constexpr int kAcross = kAlong == kB ? kB * kB : kB;
  __m256 w[kTaps];
  for (int u = 0; u < kTaps; ++u) w[u] = _mm256_set1_ps(taps[u]);
  for (int p = 0; p < kB; p += 2) {
    __m256 acc[kB];
    convolveRows8(
        present,
        [&](int s, int r) {
          const float* a = blocks[s] + p * kAcross + r * kAlong;
          return kAcross == kB ? _mm256_loadu_ps(a) : _mm256_loadu2_m128(a + kAcross, a);
        },
        w, acc);
    for (int t = 0; t < kB; ++t) {
      float* out = o + p * kAcross + t * kAlong;
      if (kAcross == kB)
        _mm256_storeu_ps(out, acc[t]);
      else
        _mm256_storeu2_m128(out + kAcross, out, acc[t]);
    }
  }
}

// Transposes each 128-bit half of four registers as 4x4 blocks (_MM_TRANSPOSE4_PS per half).
inline void transposeHalves(__m256 (&q)[kB]) {
  const __m256 t0 = _mm256_unpacklo_ps(q[0], q[1]), t1 = _mm256_unpackhi_ps(q[0], q[1]);
  const __m256 t2 = _mm256_unpacklo_ps(q[2], q[3]), t3 = _mm256_unpackhi_ps(q[2], q[3]);
  q[0] = _mm256_shuffle_ps(t0, t2, 0x44);
  q[1] = _mm256_shuffle_ps(t0, t2, 0xEE);
  q[2] = _mm256_shuffle_ps(t1, t3, 0x44);
  q[3] = _mm256_shuffle_ps(t1, t3, 0xEE);
}

// smoothBlockX, two z positions per register (each half transposed on its own).
void smoothBlockXAvx2(const float* const (&blocks)[3], const bool (&present)[3], const float* taps,
                      float* o) {
  constexpr int kPlane = kB * kB;
  __m256 w[kTaps];
  for (int u = 0; u < kTaps; ++u) w[u] = _mm256_set1_ps(taps[u]);
  for (int k = 0; k < kB; k += 2) {
    __m256 in[3][kB];
    for (int s = 0; s < 3; ++s) {
      if (!present[s]) continue;
      for (int j = 0; j < kB; ++j) {
        const float* line = blocks[s] + k * kPlane + j * kB;
        in[s][j] = _mm256_loadu2_m128(line + kPlane, line);
      }
      transposeHalves(in[s]);
    }
    __m256 acc[kB];
    convolveRows8(
        present, [&](int s, int r) { return in[s][r]; }, w, acc);
    transposeHalves(acc);
    for (int j = 0; j < kB; ++j) {
      float* line = o + k * kPlane + j * kB;
      _mm256_storeu2_m128(line + kPlane, line, acc[j]);
    }
  }
}

#pragma GCC pop_options
#endif
}  // namespace

HoughAccumulator::HoughAccumulator(HoughSpaceParams params) : params_(params) {
  a_cell_ = std::max(1e-4, params_.angle_cell_deg * kDegToRad);
  inv_a_cell_ = 1.0 / a_cell_;
  inv_d_cell_ = 1.0 / params_.d_cell_m;
  na_ = std::max(1, static_cast<int>(std::ceil(2.0 * params_.lambert_extent / a_cell_)));
  nd_ =
      std::max(1, static_cast<int>(std::ceil(params_.max_d_m / std::max(1e-4, params_.d_cell_m))));
  nba_ = (na_ + kBlock - 1) / kBlock;
  nbd_ = (nd_ + kBlock - 1) / kBlock;
  index_.assign(static_cast<std::size_t>(nba_) * nba_ * nbd_, -1);
}

void HoughAccumulator::clear() {
  for (const auto key : block_keys_) index_[key] = -1;
  block_keys_.clear();
  cells_.clear();
}

void HoughAccumulator::prepareLike(const HoughAccumulator& other) {
  if (params_.angle_cell_deg != other.params_.angle_cell_deg ||
      params_.d_cell_m != other.params_.d_cell_m || params_.max_d_m != other.params_.max_d_m ||
      params_.lambert_extent != other.params_.lambert_extent) {
    *this = HoughAccumulator(other.params_);
  }
}

Eigen::Vector3d HoughAccumulator::cellCoordinates(const Eigen::Vector3d& n, double d) const {
  const double den = 1.0 - n.z();
  if (!(den > 1e-9)) return {-1e9, -1e9, -1e9};
  const double s = std::sqrt(2.0 / den);
  return {(s * n.x() + params_.lambert_extent) * inv_a_cell_ - 0.5,
          (s * n.y() + params_.lambert_extent) * inv_a_cell_ - 0.5, d * inv_d_cell_ - 0.5};
}

[[gnu::always_inline]] inline bool HoughAccumulator::roundedCell(double ci, double cj, double ck,
                                                                 int& i, int& j, int& k) const {
  // The range test comes first (NaN fails it too), so the rounding is a truncation of a
  // non-negative value: without SSE4.1, floor is a library call, and this runs three times per
  // vote.
  if (!(ci >= 0.0 && cj >= 0.0 && ck >= 0.0 && ci < na_ && cj < na_ && ck < nd_)) return false;
  i = static_cast<int>(ci);
  j = static_cast<int>(cj);
  k = static_cast<int>(ck);
  return true;
}

bool HoughAccumulator::cellOf(const Eigen::Vector3d& n, double d, int& i, int& j, int& k) const {
  const Eigen::Vector3d c = cellCoordinates(n, d);  // rounded to the nearest cell centre:
  return roundedCell(c.x() + 0.5, c.y() + 0.5, c.z() + 0.5, i, j, k);
}

[[gnu::always_inline]] inline void HoughAccumulator::addToCellInRange(int i, int j, int k,
                                                                      float w) {
  // Non-negative indices: shifts and masks instead of signed division by the block edge.
  static_assert(kBlock == 4);
  // Most votes land in an existing block: look it up inline, call out only to create one.
  const int key = blockIndex(i >> 2, j >> 2, k >> 2);
  float* b = index_[key] >= 0 ? &cells_[static_cast<std::size_t>(index_[key]) * kBlockCells]
                              : blockOrCreate(key);
  b[cellInBlock(i & 3, j & 3, k & 3)] += w;
}

Eigen::Vector3d HoughAccumulator::normalAt(double i, double j) const {
  const double a = (i + 0.5) * a_cell_ - params_.lambert_extent;
  const double b = (j + 0.5) * a_cell_ - params_.lambert_extent;
  const double rho2 = std::min(a * a + b * b, 4.0);
  const double s = std::sqrt(std::max(0.0, 1.0 - rho2 / 4.0));
  return Eigen::Vector3d(a * s, b * s, rho2 / 2.0 - 1.0).normalized();
}

float* HoughAccumulator::blockOrCreate(int key) {
  if (index_[key] < 0) {
    index_[key] = static_cast<std::int32_t>(block_keys_.size());
    block_keys_.push_back(key);
    cells_.resize(cells_.size() + kBlockCells, 0.0f);
  }
  return &cells_[static_cast<std::size_t>(index_[key]) * kBlockCells];
}

void HoughAccumulator::addToCell(int i, int j, int k, float w) {
  if (i < 0 || j < 0 || k < 0 || i >= na_ || j >= na_ || k >= nd_) return;
  addToCellInRange(i, j, k, w);
}

void HoughAccumulator::vote(const Eigen::Vector3d& n, double d, float w) {
  int i, j, k;
  if (cellOf(n, d, i, j, k)) addToCellInRange(i, j, k, w);
}

void HoughAccumulator::voteBatch(const float* nx, const float* ny, const float* nz, const float* d,
                                 int count, float w) {
  int v = 0;
#if defined(__SSE2__)
  // One vote, from the continuous coordinates as cellOf computes them (ci = c + 0.5).
  auto add = [&](double ci, double cj, double ck) {
    int i, j, k;
    if (roundedCell(ci, cj, ck, i, j, k)) addToCellInRange(i, j, k, w);
  };
  const double ext = params_.lambert_extent;
  // cellCoordinates, two votes per SSE2 register: the same IEEE operations in the same order
  // (division and square root are correctly rounded either way), so the same cells. A normal at
  // or beyond the pole (den <= 1e-9) has no cell.
  const __m128d one = _mm_set1_pd(1.0), two = _mm_set1_pd(2.0), half = _mm_set1_pd(0.5),
                eps = _mm_set1_pd(1e-9), ext2 = _mm_set1_pd(ext), inv_a = _mm_set1_pd(inv_a_cell_),
                inv_d = _mm_set1_pd(inv_d_cell_);
  for (; v + 2 <= count; v += 2) {
    const __m128d vx = _mm_set_pd(nx[v + 1], nx[v]), vy = _mm_set_pd(ny[v + 1], ny[v]),
                  vz = _mm_set_pd(nz[v + 1], nz[v]), vd = _mm_set_pd(d[v + 1], d[v]);
    const __m128d den = _mm_sub_pd(one, vz);
    const __m128d valid = _mm_cmpgt_pd(den, eps);
    // Invalid lanes divide 2 by 1 instead (then fail the range test below).
    const __m128d sc =
        _mm_sqrt_pd(_mm_div_pd(two, _mm_or_pd(_mm_and_pd(valid, den), _mm_andnot_pd(valid, one))));
    const __m128d ci =
        _mm_add_pd(_mm_sub_pd(_mm_mul_pd(_mm_add_pd(_mm_mul_pd(sc, vx), ext2), inv_a), half), half);
    const __m128d cj =
        _mm_add_pd(_mm_sub_pd(_mm_mul_pd(_mm_add_pd(_mm_mul_pd(sc, vy), ext2), inv_a), half), half);
    const __m128d ck = _mm_add_pd(_mm_sub_pd(_mm_mul_pd(vd, inv_d), half), half);
    alignas(16) double a[2], b[2], c[2];
    _mm_store_pd(a, ci);
    _mm_store_pd(b, cj);
    _mm_store_pd(c, ck);
    const int ok = _mm_movemask_pd(valid);
    if (ok & 1) add(a[0], b[0], c[0]);
    if (ok & 2) add(a[1], b[1], c[1]);
  }
#endif
  for (; v < count; ++v) vote(Eigen::Vector3d(nx[v], ny[v], nz[v]), d[v], w);
}

float HoughAccumulator::at(int i, int j, int k) const {
  // One unsigned comparison per axis also rejects negative indices; then shifts and masks
  // (findMaxima calls this for every neighbour it compares).
  static_assert(kBlock == 4);
  if (static_cast<unsigned>(i) >= static_cast<unsigned>(na_) ||
      static_cast<unsigned>(j) >= static_cast<unsigned>(na_) ||
      static_cast<unsigned>(k) >= static_cast<unsigned>(nd_))
    return 0.0f;
  const float* b = block(blockIndex(i >> 2, j >> 2, k >> 2));
  return b ? b[cellInBlock(i & 3, j & 3, k & 3)] : 0.0f;
}

double HoughAccumulator::totalMass() const {
  return std::accumulate(cells_.begin(), cells_.end(), 0.0);
}

void HoughAccumulator::addGaussian(const Eigen::Vector3d& n, double d, double weight,
                                   double sigma_angle_deg, double sigma_d_m) {
  const Eigen::Vector3d c = cellCoordinates(n, d);
  const double sa = std::max(1e-3, sigma_angle_deg * kDegToRad / a_cell_);
  const double sd = std::max(1e-3, sigma_d_m / params_.d_cell_m);
  const int ra = std::max(1, static_cast<int>(std::ceil(2.5 * sa)));
  const int rd = std::max(1, static_cast<int>(std::ceil(2.5 * sd)));
  const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
  const int ck = static_cast<int>(std::lround(c.z()));
  // Sample, then normalise so the added mass is `weight` whatever the sub-cell offset.
  std::vector<float> w;
  w.reserve(static_cast<std::size_t>((2 * ra + 1) * (2 * ra + 1) * (2 * rd + 1)));
  double sum = 0;
  for (int k = ck - rd; k <= ck + rd; ++k)
    for (int j = cj - ra; j <= cj + ra; ++j)
      for (int i = ci - ra; i <= ci + ra; ++i) {
        const double di = (i - c.x()) / sa, dj = (j - c.y()) / sa, dk = (k - c.z()) / sd;
        const double v = std::exp(-0.5 * (di * di + dj * dj + dk * dk));
        w.push_back(static_cast<float>(v));
        sum += v;
      }
  if (!(sum > 0)) return;
  const float scale = static_cast<float>(weight / sum);
  std::size_t t = 0;
  for (int k = ck - rd; k <= ck + rd; ++k)
    for (int j = cj - ra; j <= cj + ra; ++j)
      for (int i = ci - ra; i <= ci + ra; ++i) addToCell(i, j, k, w[t++] * scale);
}

double HoughAccumulator::kernelPeak(double sigma_angle_deg, double sigma_d_m) const {
  const auto a = gaussianTaps(sigma_angle_deg * kDegToRad / a_cell_, kBlock);
  const auto d = gaussianTaps(sigma_d_m / params_.d_cell_m, kBlock);
  return static_cast<double>(a[a.size() / 2]) * a[a.size() / 2] * d[d.size() / 2];
}

void HoughAccumulator::smoothInto(HoughAccumulator& out, double sigma_angle_deg, double sigma_d_m,
                                  float min_block_mass, float min_peak) const {
  out.prepareLike(*this);
  out.clear();
  // 1. The evaluated block set: heavy blocks and their 26 neighbours.
  std::vector<float>& block_mass = out.block_mass_;  // of this space's blocks, for the peak bound
  block_mass.resize(block_keys_.size());
  const BlockNeighbourhood neighbourhood(nba_, nbd_);
  for (std::size_t b = 0; b < block_keys_.size(); ++b) {
    const float* cells = &cells_[b * kBlockCells];
    float mass = 0;
    for (int c = 0; c < kBlockCells; ++c) mass += cells[c];
    block_mass[b] = mass;
    if (mass < min_block_mass) continue;
    neighbourhood.forEach(block_keys_[b], [&](int nkey) {
      if (out.index_[nkey] < 0) out.blockOrCreate(nkey);  // (most neighbours exist already)
    });
  }
  if (out.block_keys_.empty()) return;

  // 2. Three separable passes (smoothPasses): this -> out.cells_ (x), out -> scratch (y),
  //    scratch -> out (z), over the same block set; reads see zeros outside it (and, for the
  //    first, the light blocks of this space).
  // Taps padded to the largest radius (kBlock) with zeros: fixed-size loops that unroll and
  // vectorise; the extra terms add exact zeros.
  SmoothingTaps taps{};
  const std::array<double, 3> sigma_cells = {sigma_angle_deg * kDegToRad / a_cell_,
                                             sigma_angle_deg * kDegToRad / a_cell_,
                                             sigma_d_m / params_.d_cell_m};
  for (int axis = 0; axis < 3; ++axis) {
    const std::vector<float> w = gaussianTaps(sigma_cells[axis], kBlock);
    const int r = static_cast<int>(w.size() / 2);
    for (int u = -r; u <= r; ++u) taps[axis][kBlock + u] = w[u + r];
  }
  // Which passes each evaluated block needs (kNeedX..); all of them without a peak bound.
  std::vector<std::uint8_t>& need = out.smooth_need_;
  need.assign(out.block_keys_.size(), kNeedZ);
  if (min_peak > 0.0f)
    out.pruneForPeaks(*this, block_mass, taps[0][kBlock] * taps[1][kBlock] * taps[2][kBlock],
                      min_peak);
  out.smoothPasses(*this, taps);
}

void HoughAccumulator::smoothPasses(const HoughAccumulator& src, const SmoothingTaps& taps) {
  const std::size_t count = block_keys_.size();
  const std::vector<std::uint8_t>& need = smooth_need_;
  scratch_.resize(cells_.size());  // every block the z pass reads is written first
  // Which pass results of a block may be non-zero (kLiveX: the x pass, kLiveY: the y pass).
  // A pass skips the neighbours that are absent or known to be zero: their terms are exact
  // zeros, so the sums keep their bits. A block whose x or y result is not live is never read,
  // so it is not written either.
  constexpr std::uint8_t kLiveX = 1, kLiveY = 2;
  std::vector<std::uint8_t>& live = smooth_live_;
  live.assign(count, 0);
#if defined(SHAPESENSE_AVX2_PATHS)
  const bool avx2 = detail::cpuHasAvx2();
#endif
  Quad w[3][kTaps];
  for (int axis = 0; axis < 3; ++axis)
    for (int u = 0; u < kTaps; ++u) w[axis][u] = quadSplat(taps[axis][u]);

  // x: this space's block lines are contiguous 4-cell rows; four of them (the 4 y of one z) are
  // loaded and transposed, so each register holds one x position of four lines.
  for (std::size_t b = 0; b < count; ++b) {
    const int key = block_keys_[b], bi = blockCoordsOf(key, nba_)[0];
    const float* blocks[3];
    bool present[3];
    for (int s = 0; s < 3; ++s) {
      const int x = bi + s - 1;
      blocks[s] = x >= 0 && x < nba_ ? src.block(key + s - 1) : nullptr;
      present[s] = blocks[s] != nullptr;
    }
    if (!(present[0] || present[1] || present[2])) continue;
    live[b] = kLiveX;
    float* o = &cells_[b * kBlockCells];
#if defined(SHAPESENSE_AVX2_PATHS)
    if (avx2) {
      smoothBlockXAvx2(blocks, present, taps[0].data(), o);
      continue;
    }
#endif
    smoothBlockX(blocks, present, w[0], o);
  }
  // y (cells_ -> scratch_) and z (scratch_ -> cells_): a block line's cells are kBlock (or
  // kBlock^2) apart, but the 4 lines that differ only in x are contiguous: one register.
  auto passYZ = [&](auto axis_constant, const std::vector<float>& in, std::vector<float>& dst) {
    constexpr int axis = decltype(axis_constant)::value;
    constexpr int along = axis == 1 ? kBlock : kBlock * kBlock;  // stride along the axis
    constexpr std::uint8_t needed = axis == 1 ? kNeedY : kNeedZ;
    constexpr std::uint8_t reads = axis == 1 ? kLiveX : kLiveY;
    const int step = axis == 1 ? nba_ : nba_ * nba_;  // key offset of the next block
    const int last = axis == 1 ? nba_ - 1 : nbd_ - 1;
    for (std::size_t b = 0; b < count; ++b) {
      float* o = &dst[b * kBlockCells];
      const int key = block_keys_[b];
      const float* blocks[3] = {nullptr, &in[b * kBlockCells], nullptr};
      bool present[3] = {false, (live[b] & reads) != 0, false};
      if (need[b] >= needed) {
        const int pos = blockCoordsOf(key, nba_)[axis];
        for (int s = 0; s < 3; s += 2) {
          if (s == 0 ? pos == 0 : pos == last) continue;
          const int idx = index_[key + (s - 1) * step];
          if (idx < 0 || !(live[idx] & reads)) continue;
          blocks[s] = &in[static_cast<std::size_t>(idx) * kBlockCells];
          present[s] = true;
        }
      } else {
        present[1] = false;
      }
      if (!(present[0] || present[1] || present[2])) {
        // After the z pass this is what findMaxima sees: a block that cannot hold a peak and is
        // no neighbour of one, or one without votes near it.
        if (axis == 2) std::fill_n(o, kBlockCells, 0.0f);
        continue;
      }
      if (axis == 1) live[b] |= kLiveY;
#if defined(SHAPESENSE_AVX2_PATHS)
      if (avx2) {
        smoothBlockAlongAvx2<along>(blocks, present, taps[axis].data(), o);
        continue;
      }
#endif
      smoothBlockAlong<along>(blocks, present, w[axis], o);
    }
  };
  passYZ(std::integral_constant<int, 1>{}, cells_, scratch_);
  passYZ(std::integral_constant<int, 2>{}, scratch_, cells_);
}

void HoughAccumulator::pruneForPeaks(const HoughAccumulator& src,
                                     const std::vector<float>& src_block_mass, float central_weight,
                                     float min_peak) {
  // A smoothed cell is a weighted sum, with weights <= central_weight, of the raw cells of its
  // block's 3x3x3 block neighbourhood (the kernel radius is at most a block edge): a block whose
  // neighbourhood mass times central_weight stays below min_peak holds no cell findMaxima
  // reports. 1e-3 of margin covers the float rounding of the sums (in any order), so every block
  // that can hold such a cell is kept whatever the summation order. The order does decide blocks
  // whose neighbourhood mass lies within rounding of the (margined) threshold: none of them can
  // hold a reported cell, but whether such a block is evaluated or left zero in
  // lastSmoothedSpace() depends on the summation order of the scatter below.
  const std::size_t count = block_keys_.size();
  auto inside = [&](int x, int y, int z) {
    return x >= 0 && y >= 0 && z >= 0 && x < nba_ && y < nba_ && z < nbd_;
  };
  std::vector<std::uint8_t>& need = smooth_need_;
  need.assign(count, 0);
  const BlockNeighbourhood neighbourhood(nba_, nbd_);
  // 1. The neighbourhood mass of each evaluated block, scattered from the source's blocks (all
  //    of them, light ones included: smoothed cells read them too): 27 look-ups per source
  //    block, instead of 27 per evaluated block for gathering.
  std::vector<float>& near_mass = near_mass_;
  near_mass.assign(count, 0.0f);
  for (std::size_t b = 0; b < src.block_keys_.size(); ++b) {
    const float mass = src_block_mass[b];
    neighbourhood.forEach(src.block_keys_[b], [&](int nkey) {
      const int idx = index_[nkey];
      if (idx >= 0) near_mass[idx] += mass;
    });
  }
  // 2. Peak blocks, and every evaluated block within one block of them (findMaxima compares a
  //    cell with its window of <= 2 cells and takes the centroid of its 3x3x3 cells): kNeedZ,
  //    which must come out exactly as without pruning.
  //    Nearly every evaluated block is one: each looks for a peak block around it (usually
  //    itself or the next one tried), and when all are, nothing is pruned.
  const float min_mass = min_peak / (central_weight * 1.001f);
  std::size_t near_peaks = 0;
  for (std::size_t b = 0; b < count; ++b) {
    const bool near_peak = neighbourhood.any(block_keys_[b], [&](int nkey) {
      const int idx = index_[nkey];
      return idx >= 0 && near_mass[idx] >= min_mass;
    });
    if (!near_peak) continue;
    need[b] = kNeedZ;
    ++near_peaks;
  }
  if (near_peaks == count) return;
  // 3. The z pass of a kNeedZ block reads the y pass of its z neighbours (kNeedY), whose y pass
  //    reads the x pass of their y neighbours (kNeedX). The passes read zeros outside the
  //    evaluated set, so these must keep exactly the blocks they had.
  auto raise = [&](int axis, std::uint8_t from, std::uint8_t to) {
    for (std::size_t b = 0; b < count; ++b) {
      if (need[b] < from) continue;
      const auto c = blockCoordsOf(block_keys_[b], nba_);
      for (int s = -1; s <= 1; s += 2) {
        auto n = c;
        n[axis] += s;
        if (!inside(n[0], n[1], n[2])) continue;
        const int idx = index_[blockIndex(n[0], n[1], n[2])];
        if (idx >= 0 && need[idx] < to) need[idx] = to;
      }
    }
  };
  raise(2, kNeedZ, kNeedY);
  raise(1, kNeedY, kNeedX);
  // 4. Drop the rest (the pool is still all zeros, so it is rebuilt in the same order).
  std::vector<std::int32_t> kept_keys;
  std::vector<std::uint8_t> kept_need;
  kept_keys.reserve(count);
  kept_need.reserve(count);
  for (std::size_t b = 0; b < count; ++b) {
    if (!need[b]) continue;
    kept_keys.push_back(block_keys_[b]);
    kept_need.push_back(need[b]);
  }
  if (kept_keys.size() == count) return;
  clear();
  for (const auto key : kept_keys) blockOrCreate(key);
  need.swap(kept_need);
}

std::vector<HoughMaximum> HoughAccumulator::findMaxima(float min_value, int window_a,
                                                       int window_d) const {
  // The window's offsets, nearest first: a cell that is not a maximum almost always has a larger
  // direct neighbour, so the test usually ends after a few look-ups. `earlier`: the plateau
  // tie-break (the lexicographically first cell of a plateau wins).
  struct Offset {
    int di, dj, dk;
    bool earlier;
  };
  // Generated by increasing L1 distance, each distance in (dk, dj, di) order: the order a
  // stable sort by distance of the lexicographic enumeration gives. A negative half-size counts
  // as 0 (as the in-block filter below takes it).
  window_a = std::max(0, window_a);
  window_d = std::max(0, window_d);
  std::vector<Offset> window;
  for (int l1 = 1; l1 <= 2 * window_a + window_d; ++l1)
    for (int dk = -window_d; dk <= window_d; ++dk)
      for (int dj = -window_a; dj <= window_a; ++dj)
        for (int di = -window_a; di <= window_a; ++di)
          if (std::abs(di) + std::abs(dj) + std::abs(dk) == l1)
            window.push_back({di, dj, dk, std::make_tuple(dk, dj, di) < std::make_tuple(0, 0, 0)});
  std::vector<HoughMaximum> maxima;
  // The cells of the last block along an axis that lie in the space (1..kBlock): when na_ or
  // nd_ is not a multiple of kBlock that block sticks out of the space, and the smoothing passes
  // fill whole blocks, so its cells outside hold values at() does not see (it returns 0 there).
  const int edge_a = na_ - (nba_ - 1) * kBlock, edge_d = nd_ - (nbd_ - 1) * kBlock;
  alignas(16) float clipped[kBlockCells];
  for (std::size_t b = 0; b < block_keys_.size(); ++b) {
    // The cells >= min_value, as bits (most blocks have none).
    const float* cells = &cells_[b * kBlockCells];
    std::uint64_t candidates = cellsAtLeast(cells, min_value);
    if (!candidates) continue;
    const int key = block_keys_[b];
    const auto [bi, bj, bk] = blockCoordsOf(key, nba_);
    const int ni = bi + 1 == nba_ ? edge_a : kBlock, nj = bj + 1 == nba_ ? edge_a : kBlock,
              nk = bk + 1 == nbd_ ? edge_d : kBlock;
    if (ni < kBlock || nj < kBlock || nk < kBlock) {
      // A block sticking out of the space: its cells as at() sees them (0 outside), and only
      // the cells inside can be maxima.
      std::uint64_t in_space = 0;
      for (int c = 0; c < kBlockCells; ++c) {
        const bool in = c % kBlock < ni && (c / kBlock) % kBlock < nj && c / (kBlock * kBlock) < nk;
        clipped[c] = in ? cells[c] : 0.0f;
        in_space |= static_cast<std::uint64_t>(in) << c;
      }
      cells = clipped;
      candidates &= in_space;
      if (!candidates) continue;
    }
    candidates &= ~cellsBeatenInBlock(cells, window_a >= 1, window_d >= 1);
    for (; candidates; candidates &= candidates - 1) {
      const int c = std::countr_zero(candidates);
      const float v = cells[c];
      const int i = bi * kBlock + c % kBlock, j = bj * kBlock + (c / kBlock) % kBlock;
      const int k = bk * kBlock + c / (kBlock * kBlock);
      bool is_max = true;
      for (const Offset& w : window) {
        const float o = at(i + w.di, j + w.dj, k + w.dk);
        if (o > v || (o == v && w.earlier)) {
          is_max = false;
          break;
        }
      }
      if (!is_max) continue;
      double sw = 0, si = 0, sj = 0, sk = 0;
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const double o = at(i + di, j + dj, k + dk);
            sw += o;
            si += o * di;
            sj += o * dj;
            sk += o * dk;
          }
      HoughMaximum m;
      m.i = i;
      m.j = j;
      m.k = k;
      m.value = v;
      m.normal = normalAt(i + si / sw, j + sj / sw);
      m.d = dAt(k + sk / sw);
      maxima.push_back(m);
    }
  }
  std::sort(maxima.begin(), maxima.end(), [](const HoughMaximum& a, const HoughMaximum& b) {
    return a.value > b.value ||
           (a.value == b.value && std::tie(a.k, a.j, a.i) < std::tie(b.k, b.j, b.i));
  });
  return maxima;
}

void HoughAccumulator::decay(float factor, float thinning) {
  for (std::size_t b = 0; b < block_keys_.size();) {
    float* cells = &cells_[b * kBlockCells];
    float mass = 0;
    for (int c = 0; c < kBlockCells; ++c) {
      cells[c] = std::max(0.0f, cells[c] * factor - thinning);
      mass += cells[c];
    }
    if (mass > 0) {
      ++b;
      continue;
    }
    // Free: move the last block into this slot.
    const std::size_t last = block_keys_.size() - 1;
    index_[block_keys_[b]] = -1;
    if (b != last) {
      std::copy_n(&cells_[last * kBlockCells], kBlockCells, cells);
      block_keys_[b] = block_keys_[last];
      index_[block_keys_[b]] = static_cast<std::int32_t>(b);
    }
    block_keys_.pop_back();
    cells_.resize(block_keys_.size() * kBlockCells);
  }
}

}  // namespace shapesense
