#pragma once
// SIMD kernels of the Hough accumulator (Google Highway, dispatched at run time to the best
// target the CPU supports). Every kernel gives the same bits on every target: elementwise float
// and double work with a separate multiply and add (never a fused multiply-add), in the order
// the scalar definition in each comment gives.

#include <cstdint>

namespace shapesense::hough_kernels {

constexpr int kBlock = 4;                              ///< cells per block edge
constexpr int kBlockCells = kBlock * kBlock * kBlock;  ///< cells per block, x fastest
constexpr int kTaps = 2 * kBlock + 1;                  ///< taps of a smoothing pass

/// The three source blocks of one output block along a pass's axis: the previous one, its own
/// and the next one; nullptr for a block that is absent or known to be zero (its terms would be
/// exact zeros, so skipping them keeps the bits).
using BlockTriple = const float* const[3];

/// One output block of a smoothing pass along x, y or z: out(c) = sum over u in [-kBlock,
/// kBlock], ascending, of taps[u + kBlock] * in(c + u along the axis), starting from 0, where
/// `in` is the line through the three blocks. Each product is rounded, then added.
void smoothBlockX(BlockTriple blocks, const float* taps, float* out);
void smoothBlockY(BlockTriple blocks, const float* taps, float* out);
void smoothBlockZ(BlockTriple blocks, const float* taps, float* out);

/// Bit c set when cells[c] >= min_value, for the kBlockCells cells of a block (an ordered
/// compare: a NaN cell is never set).
std::uint64_t cellsAtLeast(const float* cells, float min_value);

/// Bit c set when a direct neighbour of cell c inside the block rules it out as a maximum: a
/// larger one, or an equal one that comes earlier in (k, j, i) order. Neighbours along x and y
/// count with `lambert`, along z with `depth`.
std::uint64_t cellsBeatenInBlock(const float* cells, bool lambert, bool depth);

/// The Hough space's map from a plane to continuous cell coordinates offset by half a cell.
struct VoteSpace {
  double lambert_extent = 0;  ///< half-extent of the Lambert square
  double inv_a_cell = 0;      ///< cells per Lambert unit
  double inv_d_cell = 0;      ///< cells per metre of d
};

/// For each vote v < count (unit normal nx, ny, nz and distance d, as floats): ci, cj, ck =
/// HoughAccumulator::cellCoordinates of it, plus 0.5, in double:
///   s = sqrt(2 / (1 - nz)); ci = ((s nx + ext) inv_a - 0.5) + 0.5; cj likewise; ck = (d inv_d
///   - 0.5) + 0.5.
/// A normal at or beyond the pole (1 - nz <= 1e-9, or NaN) gets ci = -1 (outside the space).
void voteCellCoordinates(const float* nx, const float* ny, const float* nz, const float* d,
                         int count, const VoteSpace& space, double* ci, double* cj, double* ck);

}  // namespace shapesense::hough_kernels
