#pragma once
// Sparse hierarchical 3D Hough space for planes (SRS D4.6.2 section 2.2).
//
// A plane n.X + d = 0 (unit n towards the camera, d >= 0) is a point (a, b, d) of the space,
// where (a, b) is the Lambert azimuthal equal-area projection of n centred on -z (the optical
// axis looking back at the camera):  (a, b) = sqrt(2 / (1 - n_z)) * (n_x, n_y).
// Why not the two Euler angles of the seed: every Euler pair has a pole, and for a camera
// looking at a room some visible plane (floor, side wall) always sits near it, where the angle
// bins shrink and one plane's votes spread over many bins. The Lambert map is a function of the
// same two angles (polar angle t from -z, azimuth p: radius 2 sin(t/2)) with no singularity
// anywhere a visible normal can point, and it is equal-area, so a cell covers the same solid
// angle everywhere and a Gaussian kernel means the same thing everywhere. Near the centre one
// Lambert unit is one radian; at 90 deg from the axis the radial/tangential scales are 0.71/1.41.
//
// Storage is two-level: a dense, small top-level grid of block indices, and 4x4x4-cell blocks
// allocated from a pool only where votes land (a dense grid at 1.5 deg x 2 cm over a 7 m range
// would be 20+ million cells per frame, and >90% of it stays empty, as the seed observed).
// Blocks are recycled between frames, so steady-state voting does not allocate.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace shapesense {

/// Resolution and extent of a Hough space.
struct HoughSpaceParams {
  /// Cell size along each Lambert axis, expressed as the angle it spans at the centre (deg).
  /// Default 1.5: finer than the few-degree spread of per-pixel Kinect normals, so the smoothing
  /// kernel (not the grid) sets the angular resolution.
  double angle_cell_deg = 1.5;
  /// Cell size along d (m). Default 0.02 (the depth noise of a Kinect at ~2.6 m).
  double d_cell_m = 0.02;
  /// Largest plane distance represented (m); farther votes are dropped. Default 8.
  double max_d_m = 8.0;
  /// Half-extent of the Lambert square. 1.6 reaches 106 deg from -z, which covers every normal
  /// of a surface seen within the Kinect's 80 deg incidence limit. Default 1.6.
  double lambert_extent = 1.6;
};

/// A local maximum of a (smoothed) space, refined to sub-cell precision by the centre of mass
/// of its 3x3x3 neighbourhood.
struct HoughMaximum {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double d = 0.0;
  double value = 0.0;  ///< smoothed accumulator value at the maximum cell
  int i = 0, j = 0, k = 0;
};

class HoughAccumulator {
 public:
  static constexpr int kBlock = 4;  ///< cells per block edge
  static constexpr int kBlockCells = kBlock * kBlock * kBlock;

  explicit HoughAccumulator(HoughSpaceParams params = {});
  /// Copies the votes; the copy starts with empty smoothing scratch.
  HoughAccumulator(const HoughAccumulator& other);
  HoughAccumulator& operator=(const HoughAccumulator& other);
  HoughAccumulator(HoughAccumulator&&) noexcept;
  HoughAccumulator& operator=(HoughAccumulator&&) noexcept;
  ~HoughAccumulator();

  const HoughSpaceParams& params() const { return params_; }
  int cellsA() const { return na_; }  ///< cells along each Lambert axis
  int cellsD() const { return nd_; }  ///< cells along d

  /// Forgets every vote; keeps the block pool for the next frame.
  void clear();

  /// The cell of plane (n, d) (the one vote() adds to); false, with i, j, k untouched, when it
  /// lies outside the space.
  bool cellOf(const Eigen::Vector3d& n, double d, int& i, int& j, int& k) const;
  /// Continuous cell coordinates (cell centres at integers).
  Eigen::Vector3d cellCoordinates(const Eigen::Vector3d& n, double d) const;
  /// The plane at (possibly fractional) cell coordinates.
  Eigen::Vector3d normalAt(double i, double j) const;
  double dAt(double k) const { return (k + 0.5) * params_.d_cell_m; }

  /// One vote of weight w for plane (n, d) (counted, not smoothed: the seed's "caching").
  void vote(const Eigen::Vector3d& n, double d, float w = 1.0f);
  /// vote(n_i, d_i, w) for i = 0 .. count-1, in that order (the same cells, the same sums):
  /// unit normals and distances as floats, structure of arrays. Computes the cells two at a
  /// time.
  void voteBatch(const float* nx, const float* ny, const float* nz, const float* d, int count,
                 float w = 1.0f);
  void addToCell(int i, int j, int k, float w);
  float at(int i, int j, int k) const;

  /// Adds a sampled 3D Gaussian of total mass ~`weight` centred on plane (n, d) (used to add
  /// a frame's planes to the global space).
  void addGaussian(const Eigen::Vector3d& n, double d, double weight, double sigma_angle_deg,
                   double sigma_d_m);

  /// Separable Gaussian smoothing of this space into `out` (cleared first). The sigmas are in
  /// physical units; the kernel is truncated at min(ceil(2.5 sigma), 4) cells per axis (the
  /// block edge, so a block's neighbourhood is its 26 neighbour blocks). Only blocks holding
  /// mass >= `min_block_mass` and their neighbours are evaluated: isolated light blocks
  /// (scattered votes of curved surfaces) cannot form a peak worth reporting and would dominate
  /// the cost. With `min_peak` > 0 only what findMaxima(min_peak) reads is evaluated: the
  /// blocks that could hold a cell >= min_peak and their neighbours come out exactly as without
  /// it, every other block is zero (or absent). Which of those other blocks are still evaluated
  /// depends on float sums of block masses compared with a threshold: for a block within
  /// rounding of it, on the order of the additions (not on anything findMaxima(min_peak) reads).
  void smoothInto(HoughAccumulator& out, double sigma_angle_deg, double sigma_d_m,
                  float min_block_mass, float min_peak = 0.0f) const;

  /// Local maxima with value >= min_value over a sliding window of half-size (wa, wa, wd)
  /// cells (a negative half-size counts as 0: no neighbours along that axis), strongest first.
  /// Plateaus report one cell. Only cells of the space are reported
  /// (0 <= i, j < cellsA(), 0 <= k < cellsD()); the window reads at(), 0 outside the space.
  /// Cells are meant to be finite (finite votes and weights); a NaN cell is never a maximum
  /// and beats no neighbour.
  std::vector<HoughMaximum> findMaxima(float min_value, int window_a = 2, int window_d = 2) const;

  /// Multiplies every cell by `factor` and then subtracts `thinning` (the seed's "thinning"),
  /// clamping at 0; blocks whose mass falls to zero are freed.
  void decay(float factor, float thinning);

  /// Smoothed value at the centre of an isolated single vote with these sigmas (the central
  /// tap of the kernel smoothInto uses): converts a vote count into a peak height.
  double kernelPeak(double sigma_angle_deg, double sigma_d_m) const;

  std::size_t allocatedBlocks() const { return block_keys_.size(); }
  double totalMass() const;

 private:
  int blockIndex(int bi, int bj, int bk) const { return (bk * nba_ + bj) * nba_ + bi; }
  float* block(int key) {
    const int b = index_[key];
    return b < 0 ? nullptr : &cells_[static_cast<std::size_t>(b) * kBlockCells];
  }
  const float* block(int key) const {
    const int b = index_[key];
    return b < 0 ? nullptr : &cells_[static_cast<std::size_t>(b) * kBlockCells];
  }
  float* blockOrCreate(int key);
  /// Cell (i, j, k) of continuous coordinates already offset by half a cell (truncation is then
  /// rounding to the nearest centre); false when outside the space.
  bool roundedCell(double ci, double cj, double ck, int& i, int& j, int& k) const;
  /// addToCell for a cell known to lie in the space.
  void addToCellInRange(int i, int j, int k, float w);
  void prepareLike(const HoughAccumulator& other);
  // smoothInto's working buffers (output side), kept between frames so that steady-state
  // smoothing does not allocate; defined with the smoothing code.
  struct SmoothingScratch;
  SmoothingScratch& smoothingScratch();
  // Per-axis taps of smoothInto (x, y, z), padded with zeros to radius kBlock.
  using SmoothingTaps = std::array<std::array<float, 2 * kBlock + 1>, 3>;
  // smoothInto's block pruning for findMaxima(min_peak) (this = the output, blocks created and
  // still zero); fills the scratch's per-block pass needs.
  void pruneForPeaks(const HoughAccumulator& src, const std::vector<float>& src_block_mass,
                     float central_weight, float min_peak);
  // smoothInto's three passes (this = the output, its block set and pass needs ready):
  // src -> cells_ (x), cells_ -> scratch (y), scratch -> cells_ (z).
  void smoothPasses(const HoughAccumulator& src, const SmoothingTaps& taps);

  HoughSpaceParams params_;
  double a_cell_ = 0;  // Lambert units per cell
  double inv_a_cell_ = 0,
         inv_d_cell_ = 0;  // voting multiplies (a division per vote costs more than the rest)
  int na_ = 0, nd_ = 0, nba_ = 0, nbd_ = 0;
  std::vector<std::int32_t> index_;       // top level: block number or -1
  std::vector<float> cells_;              // pool: block b at [b * kBlockCells, ...)
  std::vector<std::int32_t> block_keys_;  // top-level key of each pooled block
  std::unique_ptr<SmoothingScratch> smoothing_;
};

}  // namespace shapesense
