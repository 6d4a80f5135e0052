#include "shapesense/core/planes/hough_accumulator.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numeric>
#include <tuple>
#include <type_traits>
#include <utility>

#include "planes/hough_kernels.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {

struct HoughAccumulator::SmoothingScratch {
  // Passes of smoothInto a block of the output needs: none, x, x and y, all three.
  static constexpr std::uint8_t kNeedX = 1, kNeedY = 2, kNeedZ = 3;
  std::vector<float> between_passes;  // the y pass's output, the z pass's input
  std::vector<float> block_mass;      // the source's block masses, for the peak bound
  std::vector<std::uint8_t> need;     // kNeedX.. per output block
  std::vector<std::uint8_t> live;     // smoothPasses: which pass results may be non-zero
  std::vector<float> near_mass;       // pruneForPeaks: neighbourhood mass of each block
};

HoughAccumulator::HoughAccumulator(const HoughAccumulator& other)
    : params_(other.params_),
      a_cell_(other.a_cell_),
      inv_a_cell_(other.inv_a_cell_),
      inv_d_cell_(other.inv_d_cell_),
      na_(other.na_),
      nd_(other.nd_),
      nba_(other.nba_),
      nbd_(other.nbd_),
      index_(other.index_),
      cells_(other.cells_),
      block_keys_(other.block_keys_) {}

HoughAccumulator& HoughAccumulator::operator=(const HoughAccumulator& other) {
  if (this != &other) *this = HoughAccumulator(other);
  return *this;
}

HoughAccumulator::HoughAccumulator(HoughAccumulator&&) noexcept = default;
HoughAccumulator& HoughAccumulator::operator=(HoughAccumulator&&) noexcept = default;
HoughAccumulator::~HoughAccumulator() = default;

HoughAccumulator::SmoothingScratch& HoughAccumulator::smoothingScratch() {
  if (!smoothing_) smoothing_ = std::make_unique<SmoothingScratch>();
  return *smoothing_;
}

namespace {

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
static_assert(hough_kernels::kBlock == kB && hough_kernels::kBlockCells == kB * kB * kB);

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

}  // namespace

HoughAccumulator::HoughAccumulator(HoughSpaceParams params) : params_(params) {
  a_cell_ = std::max(1e-4, degToRad(params_.angle_cell_deg));
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
  // The cells of a chunk of votes at once (the kernel), then the additions in vote order.
  constexpr int kChunk = 256;
  double ci[kChunk], cj[kChunk], ck[kChunk];
  const hough_kernels::VoteSpace space{params_.lambert_extent, inv_a_cell_, inv_d_cell_};
  for (int v = 0; v < count; v += kChunk) {
    const int n = std::min(kChunk, count - v);
    hough_kernels::voteCellCoordinates(nx + v, ny + v, nz + v, d + v, n, space, ci, cj, ck);
    for (int t = 0; t < n; ++t) {
      int i, j, k;
      if (roundedCell(ci[t], cj[t], ck[t], i, j, k)) addToCellInRange(i, j, k, w);
    }
  }
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
  const double sa = std::max(1e-3, degToRad(sigma_angle_deg) / a_cell_);
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
  const auto a = gaussianTaps(degToRad(sigma_angle_deg) / a_cell_, kBlock);
  const auto d = gaussianTaps(sigma_d_m / params_.d_cell_m, kBlock);
  return static_cast<double>(a[a.size() / 2]) * a[a.size() / 2] * d[d.size() / 2];
}

void HoughAccumulator::smoothInto(HoughAccumulator& out, double sigma_angle_deg, double sigma_d_m,
                                  float min_block_mass, float min_peak) const {
  out.prepareLike(*this);
  out.clear();
  // 1. The evaluated block set: heavy blocks and their 26 neighbours.
  std::vector<float>& block_mass =
      out.smoothingScratch().block_mass;  // of this space's blocks, for the peak bound
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
  const std::array<double, 3> sigma_cells = {degToRad(sigma_angle_deg) / a_cell_,
                                             degToRad(sigma_angle_deg) / a_cell_,
                                             sigma_d_m / params_.d_cell_m};
  for (int axis = 0; axis < 3; ++axis) {
    const std::vector<float> w = gaussianTaps(sigma_cells[axis], kBlock);
    const int r = static_cast<int>(w.size() / 2);
    for (int u = -r; u <= r; ++u) taps[axis][kBlock + u] = w[u + r];
  }
  // Which passes each evaluated block needs (kNeedX..); all of them without a peak bound.
  std::vector<std::uint8_t>& need = out.smoothingScratch().need;
  need.assign(out.block_keys_.size(), SmoothingScratch::kNeedZ);
  if (min_peak > 0.0f)
    out.pruneForPeaks(*this, block_mass, taps[0][kBlock] * taps[1][kBlock] * taps[2][kBlock],
                      min_peak);
  out.smoothPasses(*this, taps);
}

void HoughAccumulator::smoothPasses(const HoughAccumulator& src, const SmoothingTaps& taps) {
  const std::size_t count = block_keys_.size();
  SmoothingScratch& scratch = smoothingScratch();
  const std::vector<std::uint8_t>& need = scratch.need;
  scratch.between_passes.resize(cells_.size());  // every block the z pass reads is written first
  // Which pass results of a block may be non-zero (kLiveX: the x pass, kLiveY: the y pass).
  // A pass skips the neighbours that are absent or known to be zero: their terms are exact
  // zeros, so the sums keep their bits. A block whose x or y result is not live is never read,
  // so it is not written either.
  constexpr std::uint8_t kLiveX = 1, kLiveY = 2;
  std::vector<std::uint8_t>& live = scratch.live;
  live.assign(count, 0);

  // x: src -> cells_, from the source's blocks (light ones included).
  for (std::size_t b = 0; b < count; ++b) {
    const int key = block_keys_[b], bi = blockCoordsOf(key, nba_)[0];
    const float* blocks[3];
    for (int s = 0; s < 3; ++s) {
      const int x = bi + s - 1;
      blocks[s] = x >= 0 && x < nba_ ? src.block(key + s - 1) : nullptr;
    }
    if (!(blocks[0] || blocks[1] || blocks[2])) continue;
    live[b] = kLiveX;
    hough_kernels::smoothBlockX(blocks, taps[0].data(), &cells_[b * kBlockCells]);
  }
  // y (cells_ -> between_passes) and z (between_passes -> cells_), over the evaluated blocks only.
  auto passYZ = [&](auto axis_constant, const std::vector<float>& in, std::vector<float>& dst) {
    constexpr int axis = decltype(axis_constant)::value;
    constexpr std::uint8_t needed = axis == 1 ? SmoothingScratch::kNeedY : SmoothingScratch::kNeedZ;
    constexpr std::uint8_t reads = axis == 1 ? kLiveX : kLiveY;
    const int step = axis == 1 ? nba_ : nba_ * nba_;  // key offset of the next block
    const int last = axis == 1 ? nba_ - 1 : nbd_ - 1;
    for (std::size_t b = 0; b < count; ++b) {
      float* o = &dst[b * kBlockCells];
      const int key = block_keys_[b];
      const float* blocks[3] = {nullptr, nullptr, nullptr};
      if (need[b] >= needed) {
        if (live[b] & reads) blocks[1] = &in[b * kBlockCells];
        const int pos = blockCoordsOf(key, nba_)[axis];
        for (int s = 0; s < 3; s += 2) {
          if (s == 0 ? pos == 0 : pos == last) continue;
          const int idx = index_[key + (s - 1) * step];
          if (idx < 0 || !(live[idx] & reads)) continue;
          blocks[s] = &in[static_cast<std::size_t>(idx) * kBlockCells];
        }
      }
      if (!(blocks[0] || blocks[1] || blocks[2])) {
        // After the z pass this is what findMaxima sees: a block that cannot hold a peak and is
        // no neighbour of one, or one without votes near it.
        if (axis == 2) std::fill_n(o, kBlockCells, 0.0f);
        continue;
      }
      if (axis == 1) {
        live[b] |= kLiveY;
        hough_kernels::smoothBlockY(blocks, taps[axis].data(), o);
      } else {
        hough_kernels::smoothBlockZ(blocks, taps[axis].data(), o);
      }
    }
  };
  passYZ(std::integral_constant<int, 1>{}, cells_, scratch.between_passes);
  passYZ(std::integral_constant<int, 2>{}, scratch.between_passes, cells_);
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
  SmoothingScratch& scratch = smoothingScratch();
  constexpr std::uint8_t kNeedX = SmoothingScratch::kNeedX, kNeedY = SmoothingScratch::kNeedY,
                         kNeedZ = SmoothingScratch::kNeedZ;
  std::vector<std::uint8_t>& need = scratch.need;
  need.assign(count, 0);
  const BlockNeighbourhood neighbourhood(nba_, nbd_);
  // 1. The neighbourhood mass of each evaluated block, scattered from the source's blocks (all
  //    of them, light ones included: smoothed cells read them too): 27 look-ups per source
  //    block, instead of 27 per evaluated block for gathering.
  std::vector<float>& near_mass = scratch.near_mass;
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
    std::uint64_t candidates = hough_kernels::cellsAtLeast(cells, min_value);
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
    candidates &= ~hough_kernels::cellsBeatenInBlock(cells, window_a >= 1, window_d >= 1);
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
