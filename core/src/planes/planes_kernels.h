#pragma once
// SIMD kernels of plane detection and labelling (Google Highway, dispatched at run time to the
// best target the CPU supports). Each kernel is elementwise: every lane computes what the
// scalar expression in its comment computes, in that order, with a separate multiply and add
// (never a fused multiply-add), so every target gives the same bits.

#include <cstddef>
#include <cstdint>

namespace shapesense::planes_kernels {

/// Samples as structure of arrays: points, unit normals (NaN = none) and distance tolerances.
struct SampleArrays {
  const float *x, *y, *z, *nx, *ny, *nz, *tol;
};

/// A plane n . X + d = 0 and the gates of a refinement test, in float.
struct PlaneGates {
  float nx, ny, nz, d;
  float gate_mult;   ///< distance gate: gate_mult x the sample's tolerance
  float cos_normal;  ///< the normals' dot product must reach this
};

/// in[k] = (alive == nullptr || alive[k]) && dist <= gate_mult tol[k] && agrees, for k < count,
/// with dist = |((nx x + ny y) + nz z) + d| and agrees = ((nx nx_k + ny ny_k) + nz nz_k) >=
/// cos_normal (a gate_mult of 1 compares with tol[k] itself). alive holds 0 or 1.
void gateFlags(const PlaneGates& gates, const SampleArrays& samples, const std::uint8_t* alive,
               std::uint8_t* in, int count);

/// agree[i] = ((n_i.x m_i.x + n_i.y m_i.y) + n_i.z m_i.z) >= cos_max for i in [begin, end),
/// where n_i is normal i and m_i normal i + offset of `normals` (interleaved x, y, z). NaN
/// normals never agree.
void normalAgreement(const float* normals, int offset, float cos_max, int begin, int end,
                     std::uint8_t* agree);

/// How many of the n points (x, y, z) satisfy |((nx x + ny y) + nz z) + d| <= tol, in double.
std::size_t countWithin(double nx, double ny, double nz, double d, const double* x, const double* y,
                        const double* z, const double* tol, std::size_t n);

/// One row of a sample grid's points: for c < cols, z = depth_mm[c] * 0.001f (in float),
/// point c = (rx[c] z, ry z, z), or NaN x 3 where depth_mm[c] is 0. points: 3 floats per sample.
void sampleRowPoints(const std::uint16_t* depth_mm, const float* rx, float ry, int cols,
                     float* points);

/// A plane in the pinhole form of labelling: pixel (u, v) with depth z is |z ((a u + bv) + c) +
/// d| from it, where bv = b v for the row; within tolerance when that is <= max(tol_coef z^2,
/// tol_floor).
struct PixelPlane {
  float a, bv, c, d;
  float tol_coef;
};

/// Labels the pixels [u0, u1) of a row of `cols` pixels with a single candidate plane: `label`
/// where the depth is not 0 and the pixel is within tolerance (z = depth * 0.001f), 0 elsewhere.
/// Returns the number of pixels labelled. Pixels of the row outside the run may be read and
/// stored back unchanged (the last partial register): the runs of a row must be labelled left to
/// right, and no other thread may write the row meanwhile.
int labelSingleCandidateRun(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols,
                            int u0, int u1, const PixelPlane& plane, float tol_floor,
                            std::uint16_t label);

/// The same for 2 <= k <= 4 candidates: each pixel takes the label of the closest candidate
/// within its tolerance (ties to the later one), or 0. Adds the number of pixels labelled with
/// each candidate to counts[0..k).
void labelCandidatesRun(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols, int u0,
                        int u1, const PixelPlane* planes, const std::uint16_t* labels, int k,
                        float tol_floor, int* counts);

}  // namespace shapesense::planes_kernels
