#include "shapesense/eval/box_eval.h"

#include <algorithm>
#include <numeric>

namespace shapesense::eval {

double pointsBoxVolume(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d low = points.front(), high = points.front();
  for (const auto& p : points) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  return (high - low).prod();
}

void BoxModeScore::add(const BoxCorners* box, const std::vector<Eigen::Vector3d>& points) {
  ++objects;
  if (!box) {
    ++failed;
    return;
  }
  const auto inside = std::count_if(points.begin(), points.end(),
                                    [&](const Eigen::Vector3d& p) { return boxContains(*box, p); });
  coverage.push_back(points.empty() ? 0.0 : static_cast<double>(inside) / points.size());
  const double points_volume = pointsBoxVolume(points);
  volume_ratio.push_back(points_volume > 0.0 ? boxVolume(*box) / points_volume : 0.0);
}

void BoxModeScore::add(const BoxModeScore& other) {
  objects += other.objects;
  failed += other.failed;
  coverage.insert(coverage.end(), other.coverage.begin(), other.coverage.end());
  volume_ratio.insert(volume_ratio.end(), other.volume_ratio.begin(), other.volume_ratio.end());
}

double BoxModeScore::meanCoverage() const {
  return objects ? std::accumulate(coverage.begin(), coverage.end(), 0.0) / objects : 0.0;
}

std::vector<const synthetic::TruthObject*> boxableObjects(const synthetic::TruthFrame& truth,
                                                          int image_cols, int image_rows,
                                                          std::size_t min_pixels) {
  std::vector<const synthetic::TruthObject*> objects;
  for (const auto& object : truth.objects) {
    if (object.kind == "table" || object.kind == "shelf" || object.pixel_count < min_pixels)
      continue;
    const cv::Rect& b = object.image_box;
    if (b.x <= 0 || b.y <= 0 || b.x + b.width >= image_cols || b.y + b.height >= image_rows)
      continue;
    objects.push_back(&object);
  }
  return objects;
}

}  // namespace shapesense::eval
