#include "shapesense/core/recognition/object_model.h"

#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "cloud_index.h"

namespace shapesense {
namespace {

SurfaceCloud everyKth(const SurfaceCloud& cloud, int max_points) {
  const std::size_t step = detail::thinningStep(cloud.size(), max_points);
  if (step == 1) return cloud;
  SurfaceCloud out;
  for (std::size_t i = 0; i < cloud.size(); i += step) {
    out.points.push_back(cloud.points[i]);
    out.normals.push_back(cloud.normals[i]);
  }
  return out;
}

// Marks the points of `context` that lie on the object (within a voxel of one of its points).
std::vector<std::uint8_t> onObject(const SurfaceCloud& context, const SurfaceCloud& object,
                                   float voxel) {
  const detail::CloudIndex index(object.points);
  std::vector<std::uint8_t> out(context.size(), 0);
  float d2 = 0.0f;
  for (std::size_t i = 0; i < context.size(); ++i)
    if (index.nearestWithin(context.points[i], voxel, d2) >= 0) out[i] = 1;
  return out;
}

ObjectModel finishModel(std::string name, const SurfaceCloud& object,
                        std::vector<ShapeFeature> features, const ObjectModelParams& params) {
  if (static_cast<int>(features.size()) < params.min_features) {
    throw std::invalid_argument("the object shows " + std::to_string(features.size()) +
                                " shape features, fewer than the " +
                                std::to_string(params.min_features) +
                                " a model needs: a flat or featureless surface cannot be found "
                                "again by its shape");
  }
  ObjectModel model;
  model.name = std::move(name);
  model.surface = everyKth(object, params.max_surface_points);
  model.features = std::move(features);
  model.box = principalBox(object.points);
  return model;
}

void requireSurface(const SurfaceCloud& object) {
  constexpr std::size_t kMinPoints = 30;
  if (object.size() < kMinPoints) {
    throw std::invalid_argument("the object has " + std::to_string(object.size()) +
                                " surface points with depth, too few to teach");
  }
}

// Beyond each outline pixel, `offset` pixels out: where the taught view read something
// clearly farther than the object (background; not the table it stands on, an occluder, or a
// shadow that may hide either), the point at the object's depth there.
std::vector<Eigen::Vector3f> outlineProbes(const cv::Mat& depth_mm,
                                           const CameraIntrinsics& intrinsics,
                                           const cv::Mat& object_mask,
                                           const ObjectModelParams& params) {
  const int min_offset_px = params.outline_probe_offset_px;
  const KinectNoiseModel noise{};
  std::vector<Eigen::Vector3f> probes;
  const std::array<cv::Point, 4> kDirections{{{1, 0}, {-1, 0}, {0, 1}, {0, -1}}};
  for (int v = 0; v < object_mask.rows; ++v)
    for (int u = 0; u < object_mask.cols; ++u) {
      const std::uint16_t reading = depth_mm.at<std::uint16_t>(v, u);
      if (!object_mask.at<std::uint8_t>(v, u) || reading == 0) continue;
      for (const cv::Point& d : kDirections) {
        const double z = 1e-3 * reading;
        const int offset = std::max(
            min_offset_px,
            static_cast<int>(std::ceil(params.outline_probe_offset_m * intrinsics.fx / z)));
        const cv::Point next(u + d.x, v + d.y);
        const cv::Point out(u + offset * d.x, v + offset * d.y);
        if (out.x < 0 || out.y < 0 || out.x >= depth_mm.cols || out.y >= depth_mm.rows) continue;
        if (object_mask.at<std::uint8_t>(next) || object_mask.at<std::uint8_t>(out)) continue;
        const std::uint16_t beyond = depth_mm.at<std::uint16_t>(out);
        const double gap = std::max(0.02, 4.0 * noise.depthStep(z));
        if (beyond == 0 || 1e-3 * beyond < z + gap) continue;  // unknown, or near surface
        probes.push_back(intrinsics.backproject(out.x, out.y, z).cast<float>());
      }
    }
  const std::size_t step = detail::thinningStep(probes.size(), params.max_outline_probes);
  if (step == 1) return probes;
  std::vector<Eigen::Vector3f> kept;
  for (std::size_t i = 0; i < probes.size(); i += step) kept.push_back(probes[i]);
  return kept;
}

// The probes farther than `clearance` from every point of `surfaces`. A probe beside the
// object's foot hangs just over the surface it stands on, and another view reads that surface
// at the probe's depth.
std::vector<Eigen::Vector3f> clearOfSurfaces(std::vector<Eigen::Vector3f> probes,
                                             const SurfaceCloud& surfaces, float clearance) {
  const detail::CloudIndex index(surfaces.points);
  float d2 = 0.0f;
  std::erase_if(probes, [&](const Eigen::Vector3f& probe) {
    return index.nearestWithin(probe, clearance, d2) >= 0;
  });
  return probes;
}

}  // namespace

ObjectModel teachObjectModel(std::string name, const cv::Mat& depth_mm,
                             const CameraIntrinsics& intrinsics, const cv::Mat& object_mask,
                             const ObjectModelParams& params) {
  CV_Assert(object_mask.type() == CV_8UC1 && object_mask.size() == depth_mm.size());
  const SurfaceCloud object =
      surfaceCloudFromDepth(depth_mm, intrinsics, object_mask, params.surface);
  requireSurface(object);
  // The context: the pixels whose points lie within the margin of the object's box in the
  // image, then within the margin in 3D (the cloud's own neighbours decide).
  const cv::Rect box = cv::boundingRect(object_mask);
  const double z_near = [&] {
    float z = object.points.front().z();
    for (const auto& p : object.points) z = std::min(z, p.z());
    return static_cast<double>(z);
  }();
  const int margin_px =
      static_cast<int>(std::ceil(params.context_margin_m * intrinsics.fx / z_near));
  const cv::Rect grown =
      (box + cv::Size(2 * margin_px, 2 * margin_px) - cv::Point(margin_px, margin_px)) &
      cv::Rect(0, 0, depth_mm.cols, depth_mm.rows);
  cv::Mat context_mask = cv::Mat::zeros(depth_mm.size(), CV_8UC1);
  context_mask(grown).setTo(255);
  const SurfaceCloud context =
      surfaceCloudFromDepth(depth_mm, intrinsics, context_mask, params.surface);
  std::vector<ShapeFeature> features =
      detectShapeFeatures(context, params.features, Eigen::Vector3f::Zero(),
                          onObject(context, object, params.surface.voxel_m));
  ObjectModel model = finishModel(std::move(name), object, std::move(features), params);
  model.outline_probes = clearOfSurfaces(outlineProbes(depth_mm, intrinsics, object_mask, params),
                                         context, params.outline_probe_clearance_m);
  return model;
}

ObjectModel objectModelFromSurface(std::string name, const SurfaceCloud& object,
                                   const Eigen::Vector3f& viewpoint,
                                   const ObjectModelParams& params) {
  requireSurface(object);
  std::vector<ShapeFeature> features = detectShapeFeatures(object, params.features, viewpoint);
  return finishModel(std::move(name), object, std::move(features), params);
}

OrientedBox principalBox(const std::vector<Eigen::Vector3f>& points) {
  OrientedBox box;
  if (points.empty()) return box;
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<float>(points.size());
  Eigen::Matrix3f covariance = Eigen::Matrix3f::Zero();
  for (const auto& p : points) covariance += (p - mean) * (p - mean).transpose();
  Eigen::Matrix3f axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f>(covariance).eigenvectors();
  if (axes.determinant() < 0.0f) axes.col(0) = -axes.col(0);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : points) {
    const Eigen::Vector3f local = axes.transpose() * (p - mean);
    lo = lo.cwiseMin(local);
    hi = hi.cwiseMax(local);
  }
  box.axes = axes;
  box.size = hi - lo;
  box.centre = mean + axes * (0.5f * (lo + hi));
  return box;
}

}  // namespace shapesense
