#pragma once
// Neighbour queries over a fixed set of 3D points: within a radius (PointGrid) and the nearest
// within a bound (CloudIndex), both over cubes. The points must outlive either index.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace shapesense::detail {

/// floor(x) as an int, for |x| < 2^31; without SSE4.1, std::floor is a library call.
inline int floorToInt(float x) {
  const int truncated = static_cast<int>(x);
  return truncated - (x < static_cast<float>(truncated) ? 1 : 0);
}

/// The integer cell of side `size` holding `p`.
inline Eigen::Vector3i cellOf(const Eigen::Vector3f& p, float size) {
  return {floorToInt(p.x() / size), floorToInt(p.y() / size), floorToInt(p.z() / size)};
}

/// A cell as one hashable, sortable key: 21 bits a coordinate (+-1 M cells, +-5 km at 5 mm).
inline std::int64_t cellKey(const Eigen::Vector3i& cell) {
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::int64_t kMask = (1 << 21) - 1;
  const auto bits = [&](int c) { return (static_cast<std::int64_t>(c) + kOffset) & kMask; };
  return (bits(cell.x()) << 42) | (bits(cell.y()) << 21) | bits(cell.z());
}

/// The cell a cellKey was made of.
inline Eigen::Vector3i cellOfKey(std::int64_t key) {
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::int64_t kMask = (1 << 21) - 1;
  const auto coordinate = [&](int shift) {
    return static_cast<int>(((key >> shift) & kMask) - kOffset);
  };
  return {coordinate(42), coordinate(21), coordinate(0)};
}

/// A point's cell and index, for points ordered by cell.
struct CellEntry {
  std::int64_t key = 0;  ///< cellKey of the point's cell
  std::uint32_t index = 0;
};

/// The cells of side `size` of `points`, ordered by key and, within a cell, by index: the order
/// of a sort of (key, index) pairs, found by a radix sort on the cells' offsets from the
/// smallest (clouds span far fewer cells than the key can address).
std::vector<CellEntry> pointsByCell(const std::vector<Eigen::Vector3f>& points, float size);

/// Every how many-th element to keep so that at most `max_count` of `count` remain (1 = all;
/// max_count <= 0 means no limit).
inline std::size_t thinningStep(std::size_t count, int max_count) {
  if (max_count <= 0 || count <= static_cast<std::size_t>(max_count)) return 1;
  return (count + static_cast<std::size_t>(max_count) - 1) / static_cast<std::size_t>(max_count);
}

/// Points bucketed into cubes of one side: neighbour queries within a radius of a few sides,
/// for many points at once (an interest response at each point of a cloud) or one at a time.
/// A point's neighbours within r lie in the cubes up to ceil(r / side) away from its own, and
/// the candidates are gathered once per cube for all the points in it. For a whole cloud this is
/// several times faster than a k-d tree query per point, and it gives the same sets.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector3f>& points, float cube_side);

  std::size_t cubeCount() const { return cubes_.size(); }
  template <class Visit>
  void forEachPointIn(std::size_t cube, Visit&& visit) const {
    for (std::uint32_t k = cubes_[cube].begin; k < cubes_[cube].end; ++k) visit(order_[k]);
  }

  /// Calls `visit(cube, around)` for every cube in order, with the indices of the cubes that
  /// hold points among the 27 around it (itself included).
  template <class Visit>
  void forEachCube(Visit&& visit) const {
    Walk walk(*this, 1);
    std::vector<std::uint32_t> around;
    for (std::size_t cube = 0; cube < cubes_.size(); ++cube) {
      walk.cubesAround(cube, around);
      visit(cube, around);
    }
  }

  /// Calls `visit(i, neighbours)` for every point i whose `wanted[i]` is set (every point when
  /// `wanted` is empty), cube by cube; `neighbours` holds the indices of the points within
  /// `radius` of point i, i included, in no particular order.
  template <class Visit>
  void forEachPoint(float radius, const std::vector<std::uint8_t>& wanted, Visit&& visit) const {
    Walk walk(*this, reachOf(radius));
    Candidates candidates;
    std::vector<std::uint32_t> neighbours;
    for (std::size_t cube = 0; cube < cubes_.size(); ++cube) {
      bool any_wanted = wanted.empty();
      for (std::uint32_t k = cubes_[cube].begin; k < cubes_[cube].end && !any_wanted; ++k)
        any_wanted = wanted[order_[k]] != 0;
      if (!any_wanted) continue;
      walk.cubesAround(cube, candidates.cubes);
      gather(candidates);
      for (std::uint32_t k = cubes_[cube].begin; k < cubes_[cube].end; ++k) {
        const std::uint32_t i = order_[k];
        if (!wanted.empty() && !wanted[i]) continue;
        candidates.within(points_[i], radius * radius, neighbours);
        visit(i, neighbours);
      }
    }
  }

  /// The indices of the points within `radius` of `query` (any point), in no particular order.
  void withinRadius(const Eigen::Vector3f& query, float radius,
                    std::vector<std::uint32_t>& indices) const;

 private:
  friend class CloudIndex;  // searches the same cubes by column
  struct Cube {
    std::int64_t key = 0;
    std::uint32_t begin = 0;  ///< range in order_
    std::uint32_t end = 0;
  };
  // The points of the cubes around one, their coordinates copied side by side so that the
  // distance tests run over contiguous memory.
  struct Candidates {
    std::vector<std::uint32_t> cubes;
    std::vector<std::uint32_t> index;
    std::vector<float> x, y, z;
    void within(const Eigen::Vector3f& centre, float radius2,
                std::vector<std::uint32_t>& neighbours) const;
  };
  // The cubes within `reach` cubes of each cube, for cubes visited in key order: one cursor per
  // column of cubes (x, y), which only moves forward, so no search is needed.
  class Walk {
   public:
    Walk(const PointGrid& grid, int reach);
    void cubesAround(std::size_t cube, std::vector<std::uint32_t>& around);

   private:
    const PointGrid& grid_;
    int reach_;
    std::vector<std::int64_t> column_offsets_;
    std::vector<std::size_t> cursors_;
  };

  int reachOf(float radius) const;
  void gather(Candidates& candidates) const;

  const std::vector<Eigen::Vector3f>& points_;
  float side_ = 0.0f;
  std::vector<std::uint32_t> order_;  ///< point indices sorted by cube key
  std::vector<float> x_, y_, z_;      ///< the points' coordinates in that order
  std::vector<Cube> cubes_;           ///< sorted by key
};

/// The nearest point within a bound fixed at construction, as ICP's pairing and the model's
/// clearances ask it: cubes of a quarter of the bound, searched in rings around the query's cube
/// until the best point found is nearer than any unsearched cube can hold. Near pairs (most of them
/// once ICP has converged) read only the 27 cubes around the query; a k-d tree cost more to
/// build and to walk for these bounded queries.
class CloudIndex {
 public:
  CloudIndex(const std::vector<Eigen::Vector3f>& points, float bound);

  /// The nearest point at most `bound` from `query`: its index and squared distance; -1 when
  /// there is none.
  int nearestWithin(const Eigen::Vector3f& query, float& squared_distance) const;

 private:
  CloudIndex(const std::vector<Eigen::Vector3f>& points, float bound,
             const Eigen::AlignedBox3f& bounds);
  void searchRing(const Eigen::Vector3i& cell, int ring, const Eigen::Vector3f& query, float& best2,
                  int& best) const;
  void searchColumn(int x, int y, int z_low, int z_high, bool whole, const Eigen::Vector3f& query,
                    float& best2, int& best) const;

  PointGrid grid_;  ///< the points by cube, cubes in key order: each column (x, y) a run
  float bound_ = 0.0f;
  Eigen::AlignedBox3f reach_;  ///< where a query can have a point within the bound
  int rings_ = 0;
  Eigen::Vector3i low_ = Eigen::Vector3i::Zero();  ///< the smallest cell of the points
  int columns_y_ = 0;                              ///< columns (x, y) along y
  int columns_x_ = 0;
  std::vector<std::uint32_t> column_start_;  ///< per column (x, y): its first cube; then the end
  std::vector<int> cube_z_;                  ///< each cube's z cell
};

}  // namespace shapesense::detail
