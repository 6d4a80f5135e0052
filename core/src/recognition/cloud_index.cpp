#include "cloud_index.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "neighbour_kernels.h"

namespace shapesense::detail {

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

// At most about this many cubes along an axis: a cloud spread far for its bound gets larger
// cubes (and fewer rings) instead of a column table that outgrows the cloud.
constexpr float kMaxCubesAlong = 1000.0f;

// Cubes of a quarter of the bound: ICP's pairs, once it nears the pose, lie within a quarter of
// its pairing distance, and those are answered from the 27 cubes around the query.
constexpr float kSidePerBound = 0.25f;

Eigen::AlignedBox3f boundsOf(const std::vector<Eigen::Vector3f>& points) {
  Eigen::AlignedBox3f bounds;  // empty
  for (const Eigen::Vector3f& p : points) bounds.extend(p);
  return bounds;
}

float cubeSide(const Eigen::AlignedBox3f& bounds, float bound) {
  const float extent = bounds.isEmpty() ? 0.0f : bounds.sizes().maxCoeff();
  return std::max({kSidePerBound * bound, extent / kMaxCubesAlong, 1e-6f});
}

}  // namespace

CloudIndex::CloudIndex(const std::vector<Eigen::Vector3f>& points, float bound)
    : CloudIndex(points, bound, boundsOf(points)) {}

CloudIndex::CloudIndex(const std::vector<Eigen::Vector3f>& points, float bound,
                       const Eigen::AlignedBox3f& bounds)
    : grid_(points, cubeSide(bounds, bound)), bound_(bound) {
  if (points.empty()) return;
  const float side = grid_.side_;
  reach_ = bounds;
  reach_.min().array() -= bound;
  reach_.max().array() += bound;
  rings_ = std::max(1, static_cast<int>(std::ceil(bound / side)));
  low_ = cellOf(bounds.min(), side);
  const Eigen::Vector3i high = cellOf(bounds.max(), side);
  columns_x_ = high.x() - low_.x() + 1;
  columns_y_ = high.y() - low_.y() + 1;
  column_start_.assign(static_cast<std::size_t>(columns_x_) * columns_y_ + 1, 0);
  cube_z_.reserve(grid_.cubes_.size());
  for (const PointGrid::Cube& cube : grid_.cubes_) {
    const Eigen::Vector3i cell = cellOfKey(cube.key);
    cube_z_.push_back(cell.z());
    ++column_start_[static_cast<std::size_t>(cell.x() - low_.x()) * columns_y_ +
                    static_cast<std::size_t>(cell.y() - low_.y()) + 1];
  }
  for (std::size_t c = 1; c < column_start_.size(); ++c) column_start_[c] += column_start_[c - 1];
}

int CloudIndex::nearestWithin(const Eigen::Vector3f& query, float& squared_distance) const {
  if (grid_.cubes_.empty() || !reach_.contains(query)) return -1;
  // Just above the bound's square, so that a point exactly at the bound counts.
  float best2 = std::nextafter(bound_ * bound_, std::numeric_limits<float>::infinity());
  int best = -1;
  const Eigen::Vector3i cell = cellOf(query, grid_.side_);
  for (int ring = 1; ring <= rings_; ++ring) {
    searchRing(cell, ring, query, best2, best);
    // Every cube not yet searched lies beyond `ring` sides of the query.
    const float searched = static_cast<float>(ring) * grid_.side_;
    if (best >= 0 && best2 <= searched * searched) break;
  }
  if (best < 0) return -1;
  squared_distance = best2;
  return static_cast<int>(grid_.order_[static_cast<std::size_t>(best)]);
}

// The cubes whose largest offset from `cell` along an axis is `ring`; ring 1 with `cell` too.
void CloudIndex::searchRing(const Eigen::Vector3i& cell, int ring, const Eigen::Vector3f& query,
                            float& best2, int& best) const {
  for (int dx = -ring; dx <= ring; ++dx)
    for (int dy = -ring; dy <= ring; ++dy) {
      // Inside the ring's square only the top and bottom cubes of a column are on the ring.
      const bool whole_column = ring == 1 || std::max(std::abs(dx), std::abs(dy)) == ring;
      searchColumn(cell.x() + dx, cell.y() + dy, cell.z() - ring, cell.z() + ring, whole_column,
                   query, best2, best);
    }
}

void CloudIndex::searchColumn(int x, int y, int z_low, int z_high, bool whole,
                              const Eigen::Vector3f& query, float& best2, int& best) const {
  const int column_x = x - low_.x(), column_y = y - low_.y();
  if (column_x < 0 || column_y < 0 || column_x >= columns_x_ || column_y >= columns_y_) return;
  const std::size_t column =
      static_cast<std::size_t>(column_x) * columns_y_ + static_cast<std::size_t>(column_y);
  const std::uint32_t end = column_start_[column + 1];
  for (std::uint32_t c = column_start_[column]; c < end; ++c) {
    const int z = cube_z_[c];
    if (z > z_high) break;
    if (z < z_low || (!whole && z != z_low && z != z_high)) continue;
    for (std::uint32_t k = grid_.cubes_[c].begin; k < grid_.cubes_[c].end; ++k) {
      const float dx = grid_.x_[k] - query.x(), dy = grid_.y_[k] - query.y(),
                  dz = grid_.z_[k] - query.z();
      const float d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < best2) {
        best2 = d2;
        best = static_cast<int>(k);
      }
    }
  }
}

}  // namespace shapesense::detail
