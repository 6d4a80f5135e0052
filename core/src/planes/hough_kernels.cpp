// Highway kernels of the Hough accumulator (see hough_kernels.h), compiled once per SIMD target.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "planes/hough_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "planes/hough_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::hough_kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Up to 16 floats: a whole 4x4 slab of a block per register on AVX-512, half of one on AVX2, a
// block line (4 cells) on 128-bit targets.
using DF = hn::CappedTag<float, 16>;
using VF = hn::Vec<DF>;
constexpr int kPlane = kBlock * kBlock;  // cells of one z slab

#if HWY_TARGET == HWY_SCALAR
// One lane per register: each cell's sum on its own, the terms in the same order as the vector
// targets add them (ascending source block, then row).
void SmoothBlockAlong(BlockTriple blocks, const float* taps, float* out, int stride) {
  for (int c = 0; c < kBlockCells; ++c) {
    const int t = (c / stride) % kBlock;  // the cell's position along the axis
    float acc = 0.0f;
    for (int s = 0; s < 3; ++s) {
      if (blocks[s] == nullptr) continue;
      for (int r = 0; r < kBlock; ++r) {
        const int u = s * kBlock + r - kBlock - t;
        if (u >= -kBlock && u <= kBlock)
          acc = acc + taps[u + kBlock] * blocks[s][c + (r - t) * stride];
      }
    }
    out[c] = acc;
  }
}
void SmoothBlockX(BlockTriple blocks, const float* taps, float* out) {
  SmoothBlockAlong(blocks, taps, out, 1);
}
void SmoothBlockY(BlockTriple blocks, const float* taps, float* out) {
  SmoothBlockAlong(blocks, taps, out, kBlock);
}
void SmoothBlockZ(BlockTriple blocks, const float* taps, float* out) {
  SmoothBlockAlong(blocks, taps, out, kPlane);
}
#else

// Lanes of a register spread over lines of 4 cells that lie `stride` floats apart (line l of the
// register at p + l * stride).
template <class D>
HWY_INLINE hn::Vec<D> LoadLines(D d, const float* p, int stride) {
  if constexpr (hn::MaxLanes(D()) == 4) {
    return hn::LoadU(d, p);
  } else {
    const hn::Half<D> dh;
    constexpr int kHalfLines = static_cast<int>(hn::MaxLanes(D())) / 8;
    return hn::Combine(d, LoadLines(dh, p + kHalfLines * stride, stride), LoadLines(dh, p, stride));
  }
}

template <class D>
HWY_INLINE void StoreLines(D d, hn::Vec<D> v, float* p, int stride) {
  if constexpr (hn::MaxLanes(D()) == 4) {
    hn::StoreU(v, d, p);
  } else {
    const hn::Half<D> dh;
    constexpr int kHalfLines = static_cast<int>(hn::MaxLanes(D())) / 8;
    StoreLines(dh, hn::LowerHalf(dh, v), p, stride);
    StoreLines(dh, hn::UpperHalf(dh, v), p + kHalfLines * stride, stride);
  }
}

// Transposes each 128-bit part of four registers as a 4x4 matrix (row r of the matrix in q[r]).
HWY_INLINE void TransposeQuads(VF (&q)[kBlock]) {
  const DF d;
  const hn::Repartition<double, DF> dd;
  const VF t0 = hn::InterleaveLower(d, q[0], q[1]), t1 = hn::InterleaveUpper(d, q[0], q[1]);
  const VF t2 = hn::InterleaveLower(d, q[2], q[3]), t3 = hn::InterleaveUpper(d, q[2], q[3]);
  q[0] = hn::BitCast(d, hn::InterleaveLower(dd, hn::BitCast(dd, t0), hn::BitCast(dd, t2)));
  q[1] = hn::BitCast(d, hn::InterleaveUpper(dd, hn::BitCast(dd, t0), hn::BitCast(dd, t2)));
  q[2] = hn::BitCast(d, hn::InterleaveLower(dd, hn::BitCast(dd, t1), hn::BitCast(dd, t3)));
  q[3] = hn::BitCast(d, hn::InterleaveUpper(dd, hn::BitCast(dd, t1), hn::BitCast(dd, t3)));
}

// out[t] = sum over u in [-kBlock, kBlock], ascending, of w[u + kBlock] * in[kBlock + t + u],
// from 0, where in[g] = row(g / kBlock, g % kBlock): row g % kBlock of the previous (0), own
// (1) or next (2) block along the axis. Each row is loaded once and added to the outputs it
// reaches; every output still receives its terms in ascending u. Absent blocks are skipped.
template <class Row>
HWY_INLINE void ConvolveRows(BlockTriple blocks, const Row& row, const VF (&w)[kTaps],
                             VF (&out)[kBlock]) {
  const DF d;
  HWY_UNROLL(4)
  for (int t = 0; t < kBlock; ++t) out[t] = hn::Zero(d);
  HWY_UNROLL(3)
  for (int s = 0; s < 3; ++s) {
    if (blocks[s] == nullptr) continue;
    HWY_UNROLL(4)
    for (int r = 0; r < kBlock; ++r) {
      const VF x = row(s, r);
      HWY_UNROLL(4)
      for (int t = 0; t < kBlock; ++t) {
        const int u = s * kBlock + r - kBlock - t;  // the tap of in[s kBlock + r] for output t
        if (u >= -kBlock && u <= kBlock) out[t] = hn::Add(out[t], hn::Mul(w[u + kBlock], x));
      }
    }
  }
}

HWY_INLINE void SplatTaps(const float* taps, VF (&w)[kTaps]) {
  const DF d;
  for (int u = 0; u < kTaps; ++u) w[u] = hn::Set(d, taps[u]);
}

constexpr int kLinesPerVector = static_cast<int>(hn::MaxLanes(DF())) / kBlock;

// x: a block line's 4 cells are contiguous, so the 4 lines of one z (the 4 y) are loaded and
// transposed, each 128-bit part then holding one x position of four lines (one z per part).
void SmoothBlockX(BlockTriple blocks, const float* taps, float* out) {
  const DF d;
  VF w[kTaps];
  SplatTaps(taps, w);
  for (int k = 0; k < kBlock; k += kLinesPerVector) {
    VF in[3][kBlock];
    for (int s = 0; s < 3; ++s) {
      if (blocks[s] == nullptr) continue;
      for (int j = 0; j < kBlock; ++j)
        in[s][j] = LoadLines(d, blocks[s] + k * kPlane + j * kBlock, kPlane);
      TransposeQuads(in[s]);
    }
    VF acc[kBlock];
    ConvolveRows(
        blocks, [&](int s, int r) { return in[s][r]; }, w, acc);
    TransposeQuads(acc);
    for (int j = 0; j < kBlock; ++j) StoreLines(d, acc[j], out + k * kPlane + j * kBlock, kPlane);
  }
}

// y: the lines along y are kBlock apart; the 4 lines of one z that differ only in x are
// contiguous, and registers wider than 4 take the same lines of the next z slabs.
void SmoothBlockY(BlockTriple blocks, const float* taps, float* out) {
  const DF d;
  VF w[kTaps];
  SplatTaps(taps, w);
  for (int k = 0; k < kBlock; k += kLinesPerVector) {
    VF acc[kBlock];
    ConvolveRows(
        blocks,
        [&](int s, int r) { return LoadLines(d, blocks[s] + k * kPlane + r * kBlock, kPlane); }, w,
        acc);
    for (int t = 0; t < kBlock; ++t) StoreLines(d, acc[t], out + k * kPlane + t * kBlock, kPlane);
  }
}

// z: the lines along z are a slab apart; a slab's cells are contiguous.
void SmoothBlockZ(BlockTriple blocks, const float* taps, float* out) {
  const DF d;
  VF w[kTaps];
  SplatTaps(taps, w);
  for (int j = 0; j < kBlock; j += kLinesPerVector) {
    VF acc[kBlock];
    ConvolveRows(
        blocks, [&](int s, int r) { return hn::LoadU(d, blocks[s] + j * kBlock + r * kPlane); }, w,
        acc);
    for (int t = 0; t < kBlock; ++t) hn::StoreU(acc[t], d, out + j * kBlock + t * kPlane);
  }
}

#endif  // HWY_TARGET == HWY_SCALAR

// The bits of a mask over cells [c, c + lanes), shifted to bit c.
HWY_INLINE std::uint64_t MaskBitsAt(DF d, hn::Mask<DF> m, int c) {
  std::uint8_t bytes[8] = {};
  hn::StoreMaskBits(d, m, bytes);
  std::uint64_t bits = 0;
  std::memcpy(&bits, bytes, (hn::MaxLanes(d) + 7) / 8);
  return bits << c;
}

std::uint64_t CellsAtLeast(const float* cells, float min_value) {
  const DF d;
  const VF m = hn::Set(d, min_value);
  std::uint64_t bits = 0;
  for (int c = 0; c < kBlockCells; c += static_cast<int>(hn::MaxLanes(d)))
    bits |= MaskBitsAt(d, hn::Ge(hn::LoadU(d, cells + c), m), c);
  return bits;
}

std::uint64_t CellsBeatenInBlock(const float* cells, bool lambert, bool depth) {
  // Cells that have a neighbour inside the block in each direction (x fastest, then y, z).
  constexpr std::uint64_t kHasPrevX = 0xEEEEEEEEEEEEEEEEull, kHasNextX = 0x7777777777777777ull;
  constexpr std::uint64_t kHasPrevY = 0xFFF0FFF0FFF0FFF0ull, kHasNextY = 0x0FFF0FFF0FFF0FFFull;
  constexpr std::uint64_t kHasPrevZ = 0xFFFFFFFFFFFF0000ull, kHasNextZ = 0x0000FFFFFFFFFFFFull;
  // The block with a slab of padding on either side, so every neighbour load stays in bounds
  // (what the padding compares with is masked out above).
  alignas(64) float padded[kBlock * kBlock + kBlockCells + kBlock * kBlock] = {};
  std::copy_n(cells, kBlockCells, padded + kPlane);
  const float* p = padded + kPlane;
  const DF d;
  // Earlier neighbours win ties (>=), later ones only when larger.
  auto beatenBy = [&](int offset, std::uint64_t has_neighbour) {
    std::uint64_t bits = 0;
    for (int c = 0; c < kBlockCells; c += static_cast<int>(hn::MaxLanes(d))) {
      const VF v = hn::LoadU(d, p + c), o = hn::LoadU(d, p + c + offset);
      bits |= MaskBitsAt(d, offset < 0 ? hn::Ge(o, v) : hn::Gt(o, v), c);
    }
    return bits & has_neighbour;
  };
  std::uint64_t bits = 0;
  if (lambert)
    bits |= beatenBy(-1, kHasPrevX) | beatenBy(1, kHasNextX) | beatenBy(-kBlock, kHasPrevY) |
            beatenBy(kBlock, kHasNextY);
  if (depth) bits |= beatenBy(-kPlane, kHasPrevZ) | beatenBy(kPlane, kHasNextZ);
  return bits;
}

void VoteCellCoordinates(const float* nx, const float* ny, const float* nz, const float* d,
                         int count, const VoteSpace& space, double* ci, double* cj, double* ck) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  const auto one = hn::Set(dd, 1.0), two = hn::Set(dd, 2.0), half = hn::Set(dd, 0.5),
             eps = hn::Set(dd, 1e-9), ext = hn::Set(dd, space.lambert_extent),
             inv_a = hn::Set(dd, space.inv_a_cell), inv_d = hn::Set(dd, space.inv_d_cell),
             outside = hn::Set(dd, -1.0);
  int v = 0;
  for (; v + lanes <= count; v += lanes) {
    const auto vx = hn::PromoteTo(dd, hn::LoadU(df, nx + v));
    const auto vy = hn::PromoteTo(dd, hn::LoadU(df, ny + v));
    const auto vz = hn::PromoteTo(dd, hn::LoadU(df, nz + v));
    const auto vd = hn::PromoteTo(dd, hn::LoadU(df, d + v));
    const auto den = hn::Sub(one, vz);
    const auto valid = hn::Gt(den, eps);
    // Invalid lanes divide 2 by 1 instead, then take the outside value.
    const auto s = hn::Sqrt(hn::Div(two, hn::IfThenElse(valid, den, one)));
    const auto a = hn::Add(hn::Sub(hn::Mul(hn::Add(hn::Mul(s, vx), ext), inv_a), half), half);
    const auto b = hn::Add(hn::Sub(hn::Mul(hn::Add(hn::Mul(s, vy), ext), inv_a), half), half);
    const auto c = hn::Add(hn::Sub(hn::Mul(vd, inv_d), half), half);
    hn::StoreU(hn::IfThenElse(valid, a, outside), dd, ci + v);
    hn::StoreU(b, dd, cj + v);
    hn::StoreU(c, dd, ck + v);
  }
  for (; v < count; ++v) {
    const double den = 1.0 - static_cast<double>(nz[v]);
    const double s = std::sqrt(2.0 / (den > 1e-9 ? den : 1.0));
    ci[v] = den > 1e-9 ? ((s * nx[v] + space.lambert_extent) * space.inv_a_cell - 0.5) + 0.5 : -1.0;
    cj[v] = ((s * ny[v] + space.lambert_extent) * space.inv_a_cell - 0.5) + 0.5;
    ck[v] = (static_cast<double>(d[v]) * space.inv_d_cell - 0.5) + 0.5;
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::hough_kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::hough_kernels {

HWY_EXPORT(SmoothBlockX);
HWY_EXPORT(SmoothBlockY);
HWY_EXPORT(SmoothBlockZ);
HWY_EXPORT(CellsAtLeast);
HWY_EXPORT(CellsBeatenInBlock);
HWY_EXPORT(VoteCellCoordinates);

void smoothBlockX(BlockTriple blocks, const float* taps, float* out) {
  HWY_DYNAMIC_DISPATCH(SmoothBlockX)(blocks, taps, out);
}
void smoothBlockY(BlockTriple blocks, const float* taps, float* out) {
  HWY_DYNAMIC_DISPATCH(SmoothBlockY)(blocks, taps, out);
}
void smoothBlockZ(BlockTriple blocks, const float* taps, float* out) {
  HWY_DYNAMIC_DISPATCH(SmoothBlockZ)(blocks, taps, out);
}
std::uint64_t cellsAtLeast(const float* cells, float min_value) {
  return HWY_DYNAMIC_DISPATCH(CellsAtLeast)(cells, min_value);
}
std::uint64_t cellsBeatenInBlock(const float* cells, bool lambert, bool depth) {
  return HWY_DYNAMIC_DISPATCH(CellsBeatenInBlock)(cells, lambert, depth);
}
void voteCellCoordinates(const float* nx, const float* ny, const float* nz, const float* d,
                         int count, const VoteSpace& space, double* ci, double* cj, double* ck) {
  HWY_DYNAMIC_DISPATCH(VoteCellCoordinates)(nx, ny, nz, d, count, space, ci, cj, ck);
}

}  // namespace shapesense::hough_kernels
#endif  // HWY_ONCE
