#pragma once
// Radius and nearest-neighbour queries over a fixed set of 3D points (a k-d tree from
// nanoflann). The points must outlive the index.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace shapesense::detail {

/// The integer cell of side `size` holding `p`.
inline Eigen::Vector3i cellOf(const Eigen::Vector3f& p, float size) {
  return (p / size).array().floor().cast<int>();
}

/// A cell as one hashable, sortable key: 21 bits a coordinate (+-1 M cells, +-5 km at 5 mm).
inline std::int64_t cellKey(const Eigen::Vector3i& cell) {
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::int64_t kMask = (1 << 21) - 1;
  const auto bits = [&](int c) { return (static_cast<std::int64_t>(c) + kOffset) & kMask; };
  return (bits(cell.x()) << 42) | (bits(cell.y()) << 21) | bits(cell.z());
}

class CloudIndex {
 public:
  explicit CloudIndex(const std::vector<Eigen::Vector3f>& points);
  ~CloudIndex();
  CloudIndex(const CloudIndex&) = delete;
  CloudIndex& operator=(const CloudIndex&) = delete;

  /// The indices of the points within `radius` of `query`, in no particular order.
  void withinRadius(const Eigen::Vector3f& query, float radius,
                    std::vector<std::uint32_t>& indices) const;
  /// The nearest point's index and its squared distance; -1 for an empty set.
  int nearest(const Eigen::Vector3f& query, float& squared_distance) const;

  const std::vector<Eigen::Vector3f>& points() const { return points_; }

 private:
  struct Tree;
  const std::vector<Eigen::Vector3f>& points_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace shapesense::detail
