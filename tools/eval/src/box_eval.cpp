#include "shapesense/eval/box_eval.h"

#include <algorithm>
#include <map>
#include <numeric>

namespace shapesense::eval {
namespace {

// The 3D points of the pixels where `is_object(label)` holds and the depth has a reading.
template <typename Predicate>
std::vector<Eigen::Vector3d> labelledPoints(const cv::Mat& labels, const cv::Mat& depth_mm,
                                            const CameraIntrinsics& intrinsics,
                                            Predicate is_object) {
  std::vector<Eigen::Vector3d> points;
  for (int v = 0; v < labels.rows; ++v) {
    const auto* label = labels.ptr<std::uint16_t>(v);
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (depth[u] != 0 && is_object(label[u]))
        points.push_back(intrinsics.backproject(u, v, 1e-3 * depth[u]));
  }
  return points;
}

}  // namespace

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

double BoxModeScore::shareMeeting(double min_coverage, double max_volume_ratio) const {
  int meeting = 0;
  for (std::size_t i = 0; i < coverage.size(); ++i)
    meeting += coverage[i] >= min_coverage && volume_ratio[i] <= max_volume_ratio;
  return objects ? static_cast<double>(meeting) / objects : 0.0;
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

std::vector<BoxTarget> syntheticBoxTargets(const synthetic::RenderedFrame& rendered,
                                           double min_image_share) {
  const Frame& frame = rendered.frame;
  std::vector<BoxTarget> targets;
  for (const auto* object :
       boxableObjects(rendered.truth, frame.depth.cols, frame.depth.rows,
                      static_cast<std::size_t>(min_image_share * frame.depth.total()))) {
    targets.push_back({object->image_box,
                       labelledPoints(rendered.truth.object_labels, frame.depth, frame.intrinsics,
                                      [&](std::uint16_t label) { return label == object->id; })});
  }
  return targets;
}

std::vector<BoxTarget> realBoxTargets(const LabelledFrame& frame, double min_image_share) {
  std::map<int, cv::Rect> bounds;
  for (int v = 0; v < frame.labels.rows; ++v)
    for (int u = 0; u < frame.labels.cols; ++u) {
      const int owner = osdOwner(frame.labels.at<std::uint16_t>(v, u));
      if (owner <= 0 || frame.frame.depth.at<std::uint16_t>(v, u) == 0) continue;
      cv::Rect& b = bounds[owner];
      b = b.area() == 0 ? cv::Rect(u, v, 1, 1) : (b | cv::Rect(u, v, 1, 1));
    }
  std::vector<BoxTarget> targets;
  for (const auto& [owner, roi] : bounds) {
    auto points =
        labelledPoints(frame.labels, frame.frame.depth, frame.frame.intrinsics,
                       [owner = owner](std::uint16_t label) { return osdOwner(label) == owner; });
    if (points.size() >= min_image_share * frame.frame.depth.total())
      targets.push_back({roi, std::move(points)});
  }
  return targets;
}

}  // namespace shapesense::eval
