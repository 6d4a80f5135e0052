#include "cloud_index.h"

#include <nanoflann.hpp>

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

void CloudIndex::withinRadius(const Eigen::Vector3f& query, float radius,
                              std::vector<std::uint32_t>& indices) const {
  indices.clear();
  if (points_.empty()) return;
  // nanoflann's L2 metric works in squared distances.
  std::vector<std::pair<std::uint32_t, float>> found;
  tree_->tree.radiusSearch(query.data(), radius * radius, found,
                           nanoflann::SearchParams(32, 0.0f, false));
  indices.reserve(found.size());
  for (const auto& [index, distance] : found) indices.push_back(index);
}

int CloudIndex::nearest(const Eigen::Vector3f& query, float& squared_distance) const {
  if (points_.empty()) return -1;
  std::uint32_t index = 0;
  tree_->tree.knnSearch(query.data(), 1, &index, &squared_distance);
  return static_cast<int>(index);
}

}  // namespace shapesense::detail
