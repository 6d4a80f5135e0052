#include "cloud_index.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <nanoflann.hpp>

#include "neighbour_kernels.h"

namespace shapesense::detail {
namespace {

struct PointsAdaptor {
  const std::vector<Eigen::Vector3f>& points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(std::size_t index, std::size_t dim) const { return points[index][dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsAdaptor>,
                                        PointsAdaptor, 3, std::uint32_t>;

}  // namespace

struct CloudIndex::Tree {
  explicit Tree(const std::vector<Eigen::Vector3f>& points)
      : adaptor{points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree.buildIndex();
  }
  PointsAdaptor adaptor;
  KdTree tree;
};

CloudIndex::CloudIndex(const std::vector<Eigen::Vector3f>& points)
    : points_(points), tree_(std::make_unique<Tree>(points)) {}

CloudIndex::~CloudIndex() = default;

namespace {

// Cube keys (cellKey) pack (x, y, z) with z lowest: a column of cubes along z is a run of
// consecutive keys, and a step in y or x adds these.
constexpr std::int64_t kKeyStepY = std::int64_t{1} << 21;
constexpr std::int64_t kKeyStepX = std::int64_t{1} << 42;

}  // namespace

namespace {

int bitsFor(int range) {
  int bits = 0;
  while (bits < 31 && (1 << bits) <= range) ++bits;
  return bits;
}

// Stable LSD radix sort of `values` on bits [32, 32 + key_bits) of each, in as few passes of
// at most 11 bits as cover them (2048 counters stay in the first-level cache).
void radixSortUpperBits(std::vector<std::uint64_t>& values, int key_bits) {
  const int passes = (key_bits + 10) / 11;
  if (passes == 0) return;
  const int digit_bits = (key_bits + passes - 1) / passes;
  const std::uint64_t digit_mask = (std::uint64_t{1} << digit_bits) - 1;
  std::vector<std::uint64_t> buffer(values.size());
  std::vector<std::size_t> start((std::size_t{1} << digit_bits) + 1);
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = 32 + pass * digit_bits;
    std::fill(start.begin(), start.end(), 0);
    for (const std::uint64_t v : values) ++start[((v >> shift) & digit_mask) + 1];
    for (std::size_t d = 1; d < start.size(); ++d) start[d] += start[d - 1];
    for (const std::uint64_t v : values) buffer[start[(v >> shift) & digit_mask]++] = v;
    values.swap(buffer);
  }
}

}  // namespace

std::vector<CellEntry> pointsByCell(const std::vector<Eigen::Vector3f>& points, float size) {
  std::vector<CellEntry> out(points.size());
  if (points.empty()) return out;
  // The cells' bounds are the cells of the points' bounds (a cell's index grows with each
  // coordinate): each point's cell is computed once, when it is packed.
  Eigen::Vector3f lowest = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f highest = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
  for (const Eigen::Vector3f& p : points) {
    lowest = lowest.cwiseMin(p);
    highest = highest.cwiseMax(p);
  }
  const Eigen::Vector3i low = cellOf(lowest, size);
  const Eigen::Vector3i high = cellOf(highest, size);
  const Eigen::Vector3i range = high - low;
  const int bits_y = bitsFor(range.y()), bits_z = bitsFor(range.z());
  const int key_bits = bitsFor(range.x()) + bits_y + bits_z;
  if (key_bits > 32) {
    for (std::size_t i = 0; i < points.size(); ++i)
      out[i] = {cellKey(cellOf(points[i], size)), static_cast<std::uint32_t>(i)};
    std::sort(out.begin(), out.end(), [](const CellEntry& a, const CellEntry& b) {
      return a.key != b.key ? a.key < b.key : a.index < b.index;
    });
    return out;
  }
  // The offsets packed x, y, z from the highest bits down order the cells as their keys do.
  std::vector<std::uint64_t> packed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i offset = cellOf(points[i], size) - low;
    const std::uint64_t compact = (static_cast<std::uint64_t>(offset.x()) << (bits_y + bits_z)) |
                                  (static_cast<std::uint64_t>(offset.y()) << bits_z) |
                                  static_cast<std::uint64_t>(offset.z());
    packed[i] = (compact << 32) | i;
  }
  radixSortUpperBits(packed, key_bits);
  // The cell back from the packed offsets: in sorted order, reading the points again would be a
  // read from anywhere in memory per point.
  const std::uint64_t mask_y = (std::uint64_t{1} << bits_y) - 1;
  const std::uint64_t mask_z = (std::uint64_t{1} << bits_z) - 1;
  for (std::size_t k = 0; k < packed.size(); ++k) {
    const std::uint64_t compact = packed[k] >> 32;
    const Eigen::Vector3i cell =
        low + Eigen::Vector3i(static_cast<int>(compact >> (bits_y + bits_z)),
                              static_cast<int>((compact >> bits_z) & mask_y),
                              static_cast<int>(compact & mask_z));
    out[k] = {cellKey(cell), static_cast<std::uint32_t>(packed[k] & 0xFFFFFFFFu)};
  }
  return out;
}

PointGrid::PointGrid(const std::vector<Eigen::Vector3f>& points, float cube_side)
    : points_(points), side_(cube_side) {
  const std::vector<CellEntry> keyed = pointsByCell(points, cube_side);
  order_.resize(keyed.size());
  x_.resize(keyed.size());
  y_.resize(keyed.size());
  z_.resize(keyed.size());
  for (std::size_t k = 0; k < keyed.size(); ++k) {
    order_[k] = keyed[k].index;
    const Eigen::Vector3f& p = points[keyed[k].index];
    x_[k] = p.x();
    y_[k] = p.y();
    z_[k] = p.z();
    if (cubes_.empty() || cubes_.back().key != keyed[k].key)
      cubes_.push_back({keyed[k].key, static_cast<std::uint32_t>(k), 0});
    cubes_.back().end = static_cast<std::uint32_t>(k + 1);
  }
}

int PointGrid::reachOf(float radius) const {
  return std::max(1, static_cast<int>(std::ceil(radius / side_)));
}

PointGrid::Walk::Walk(const PointGrid& grid, int reach) : grid_(grid), reach_(reach) {
  for (int dx = -reach; dx <= reach; ++dx)
    for (int dy = -reach; dy <= reach; ++dy)
      column_offsets_.push_back(dx * kKeyStepX + dy * kKeyStepY - reach);
  cursors_.assign(column_offsets_.size(), 0);
}

void PointGrid::Walk::cubesAround(std::size_t cube, std::vector<std::uint32_t>& around) {
  around.clear();
  const auto& cubes = grid_.cubes_;
  const std::int64_t centre = cubes[cube].key;
  for (std::size_t column = 0; column < column_offsets_.size(); ++column) {
    const std::int64_t first = centre + column_offsets_[column];
    std::size_t& cursor = cursors_[column];
    while (cursor < cubes.size() && cubes[cursor].key < first) ++cursor;
    for (std::size_t c = cursor; c < cubes.size() && cubes[c].key <= first + 2 * reach_; ++c)
      around.push_back(static_cast<std::uint32_t>(c));
  }
}

void PointGrid::gather(Candidates& candidates) const {
  std::size_t total = 0;
  for (std::uint32_t c : candidates.cubes) total += cubes_[c].end - cubes_[c].begin;
  candidates.index.resize(total);
  candidates.x.resize(total);
  candidates.y.resize(total);
  candidates.z.resize(total);
  std::size_t at = 0;
  for (std::uint32_t c : candidates.cubes) {
    const std::uint32_t begin = cubes_[c].begin, end = cubes_[c].end;
    std::copy(order_.begin() + begin, order_.begin() + end, candidates.index.begin() + at);
    std::copy(x_.begin() + begin, x_.begin() + end, candidates.x.begin() + at);
    std::copy(y_.begin() + begin, y_.begin() + end, candidates.y.begin() + at);
    std::copy(z_.begin() + begin, z_.begin() + end, candidates.z.begin() + at);
    at += end - begin;
  }
}

void PointGrid::Candidates::within(const Eigen::Vector3f& centre, float radius2,
                                   std::vector<std::uint32_t>& neighbours) const {
  neighbours.resize(index.size() + kIndicesWithinSlack);
  const std::size_t count =
      indicesWithin({x.data(), y.data(), z.data(), index.data(), index.size()}, centre.x(),
                    centre.y(), centre.z(), radius2, neighbours.data());
  neighbours.resize(count);
}

void PointGrid::withinRadius(const Eigen::Vector3f& query, float radius,
                             std::vector<std::uint32_t>& indices) const {
  const int reach = reachOf(radius);
  const std::int64_t centre = cellKey(cellOf(query, side_));
  Candidates candidates;
  for (int dx = -reach; dx <= reach; ++dx)
    for (int dy = -reach; dy <= reach; ++dy) {
      const std::int64_t first = centre + dx * kKeyStepX + dy * kKeyStepY - reach;
      auto it = std::lower_bound(cubes_.begin(), cubes_.end(), first,
                                 [](const Cube& c, std::int64_t key) { return c.key < key; });
      for (; it != cubes_.end() && it->key <= first + 2 * reach; ++it)
        candidates.cubes.push_back(static_cast<std::uint32_t>(it - cubes_.begin()));
    }
  gather(candidates);
  candidates.within(query, radius * radius, indices);
}

namespace {

// A nanoflann result set holding the nearest point closer than a bound: the search prunes
// every branch farther than the best found so far, which starts at the bound.
class NearestWithinBound {
 public:
  using DistanceType = float;
  using IndexType = std::uint32_t;
  using CountType = std::size_t;

  explicit NearestWithinBound(float bound2) : best_(bound2) {}
  CountType size() const { return found_ ? 1 : 0; }
  bool full() const { return true; }
  bool addPoint(float squared_distance, std::uint32_t index) {
    if (squared_distance < best_) {
      best_ = squared_distance;
      index_ = index;
      found_ = true;
    }
    return true;
  }
  float worstDist() const { return best_; }
  bool found() const { return found_; }
  std::uint32_t index() const { return index_; }

 private:
  float best_;
  std::uint32_t index_ = 0;
  bool found_ = false;
};

}  // namespace

int CloudIndex::nearestWithin(const Eigen::Vector3f& query, float max_distance,
                              float& squared_distance) const {
  if (points_.empty()) return -1;
  // Just above the bound's square, so that a point exactly at max_distance counts.
  const float bound2 =
      std::nextafter(max_distance * max_distance, std::numeric_limits<float>::infinity());
  NearestWithinBound result(bound2);
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  if (!result.found()) return -1;
  squared_distance = result.worstDist();
  return static_cast<int>(result.index());
}

}  // namespace shapesense::detail
