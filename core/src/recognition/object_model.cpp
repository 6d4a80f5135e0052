#include "shapesense/core/recognition/object_model.h"

#include <optional>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "shapesense/core/geometry/depth_step.h"
#include "shapesense/core/planes/planes.h"

#include "cloud_index.h"

namespace shapesense {
namespace {

// The steepest face (depth change over lateral distance) that is extended past the outline,
// tan 63 deg: steeper, the face is seen nearly edge-on and its extension is ill-defined.
constexpr double kMaxFaceSlope = 2.0;
// Readings this far apart lie on surfaces told apart for sure: a probe's depth and what the
// taught view reads there (at least 4 sensor steps and 2 cm).
const DepthStepRule kSurfacesApart{.noise_steps = 4.0, .range_fraction = 0.0, .floor_m = 0.02};
// A surface in front of a probe touches the object when it lies within this many probe
// offsets of the outline (plus the sensor's noise): one seen at a glancing angle reads farther.
constexpr double kTouchingReach = 4.0;

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
  const detail::CloudIndex index(object.points, voxel);
  std::vector<std::uint8_t> out(context.size(), 0);
  float d2 = 0.0f;
  for (std::size_t i = 0; i < context.size(); ++i)
    if (index.nearestWithin(context.points[i], d2) >= 0) out[i] = 1;
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
  model.flat_faces = flatFacesOfSurface(model.surface, params.flat_faces);
  return model;
}

void requireSurface(const SurfaceCloud& object) {
  constexpr std::size_t kMinPoints = 30;
  if (object.size() < kMinPoints) {
    throw std::invalid_argument("the object has " + std::to_string(object.size()) +
                                " surface points with depth, too few to teach");
  }
}

// For every pixel off the object, its distance from the object's pixels with depth and the
// nearest of them.
struct NearestObjectPixels {
  cv::Mat distance;              ///< CV_32F, pixels; 0 on the object
  cv::Mat label;                 ///< CV_32S, distanceTransform's label of the nearest object pixel
  std::vector<cv::Point> pixel;  ///< the object pixel of each label

  explicit NearestObjectPixels(const cv::Mat& object_with_depth)
      : pixel(object_with_depth.total() + 1) {
    cv::distanceTransform(object_with_depth == 0, distance, label, cv::DIST_L2, cv::DIST_MASK_5,
                          cv::DIST_LABEL_PIXEL);
    // Each object pixel carries a label of its own.
    for (int v = 0; v < object_with_depth.rows; ++v)
      for (int u = 0; u < object_with_depth.cols; ++u)
        if (object_with_depth.at<std::uint8_t>(v, u))
          pixel[static_cast<std::size_t>(label.at<int>(v, u))] = cv::Point(u, v);
  }
  cv::Point nearestTo(cv::Point p) const {
    return pixel[static_cast<std::size_t>(label.at<int>(p))];
  }
};

// The depth of the object's face extended from `edge` out to `outside`: inverse depth is linear
// in the image along a plane; fitted to the object pixels 2-10 px inward from the edge (past
// its flying pixels) and extrapolated. 0 when too few of them have depth.
double extendedFaceDepth(const cv::Mat& depth_mm, const cv::Mat& object_with_depth,
                         cv::Point outside, cv::Point edge) {
  const Eigen::Vector2d from(outside.x, outside.y);
  const Eigen::Vector2d to_edge = Eigen::Vector2d(edge.x, edge.y) - from;
  const Eigen::Vector2d inward = to_edge.normalized();
  double n = 0, sum_s = 0, sum_w = 0, sum_ss = 0, sum_sw = 0;
  for (int k = 2; k <= 10; ++k) {
    const double s = to_edge.norm() + k;
    const Eigen::Vector2d at = from + s * inward;
    const cv::Point pixel(static_cast<int>(std::lround(at.x())),
                          static_cast<int>(std::lround(at.y())));
    if (pixel.x < 0 || pixel.y < 0 || pixel.x >= depth_mm.cols || pixel.y >= depth_mm.rows) break;
    if (!object_with_depth.at<std::uint8_t>(pixel)) continue;
    const double w = 1e3 / depth_mm.at<std::uint16_t>(pixel);
    n += 1;
    sum_s += s;
    sum_w += w;
    sum_ss += s * s;
    sum_sw += s * w;
  }
  constexpr double kMinSamples = 5;
  const double denominator = n * sum_ss - sum_s * sum_s;
  if (n < kMinSamples || denominator <= 0.0) return 0.0;
  const double slope = (n * sum_sw - sum_s * sum_w) / denominator;
  const double w_outside = (sum_w - slope * sum_s) / n;
  return w_outside > 0.0 ? 1.0 / w_outside : 0.0;
}

// Beyond the outline of a face: the point on the face's extension, kept where the taught view
// shows that the face does not go on there. What it shows instead is background behind the
// probe, or something in front that touches the object at the outline (what it stands on or
// leans against); not an occluder, behind which the face may go on.
std::optional<Eigen::Vector3f> faceProbe(cv::Point outside, cv::Point edge, double edge_z,
                                         double probe_z, double beyond_z,
                                         const CameraIntrinsics& intrinsics,
                                         const ObjectModelParams& params) {
  if (std::abs(beyond_z - probe_z) < kSurfacesApart.threshold(probe_z)) return std::nullopt;
  if (beyond_z < probe_z) {
    const Eigen::Vector3d in_front = intrinsics.backproject(outside.x, outside.y, beyond_z);
    const Eigen::Vector3d at_edge = intrinsics.backproject(edge.x, edge.y, edge_z);
    const double touching =
        kTouchingReach * params.outline_probe_offset_m + 2.0 * KinectNoiseModel{}.depthStep(edge_z);
    if ((in_front - at_edge).norm() > touching) return std::nullopt;
  }
  return intrinsics.backproject(outside.x, outside.y, probe_z).cast<float>();
}

// Beyond a silhouette (a face seen edge-on, as a curved object's sides are): the point at the
// outline's depth, kept where the taught view saw background behind it.
std::optional<Eigen::Vector3f> silhouetteProbe(cv::Point outside, double edge_z, double beyond_z,
                                               const CameraIntrinsics& intrinsics) {
  if (beyond_z < edge_z + kSurfacesApart.threshold(edge_z)) return std::nullopt;
  return intrinsics.backproject(outside.x, outside.y, edge_z).cast<float>();
}

// Points where the taught view shows that the object ends, one from each pixel with a reading
// whose distance from the object's pixels is the probe offset at the depth of the nearest one
// (so that a probe clears the outline by that much in every direction, slanted outlines too).
std::vector<Eigen::Vector3f> outlineProbes(const cv::Mat& depth_mm,
                                           const CameraIntrinsics& intrinsics,
                                           const cv::Mat& object_mask,
                                           const ObjectModelParams& params) {
  const cv::Mat object_with_depth = object_mask & (depth_mm > 0);
  if (cv::countNonZero(object_with_depth) == 0) return {};
  const NearestObjectPixels nearest(object_with_depth);
  std::vector<Eigen::Vector3f> probes;
  for (int v = 0; v < depth_mm.rows; ++v)
    for (int u = 0; u < depth_mm.cols; ++u) {
      const cv::Point outside(u, v);
      const float from_object = nearest.distance.at<float>(outside);
      const std::uint16_t beyond = depth_mm.at<std::uint16_t>(outside);
      if (from_object == 0.0f || beyond == 0) continue;
      const cv::Point edge = nearest.nearestTo(outside);
      const double edge_z = 1e-3 * depth_mm.at<std::uint16_t>(edge);
      const double offset = std::max<double>(
          params.outline_probe_offset_px, params.outline_probe_offset_m * intrinsics.fx / edge_z);
      if (from_object < offset || from_object >= offset + 1.0) continue;
      const double probe_z = extendedFaceDepth(depth_mm, object_with_depth, outside, edge);
      const bool face_extends =
          probe_z > 0.0 &&
          std::abs(probe_z - edge_z) <= kMaxFaceSlope * from_object * edge_z / intrinsics.fx;
      const std::optional<Eigen::Vector3f> probe =
          face_extends
              ? faceProbe(outside, edge, edge_z, probe_z, 1e-3 * beyond, intrinsics, params)
              : silhouetteProbe(outside, edge_z, 1e-3 * beyond, intrinsics);
      if (probe) probes.push_back(*probe);
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
  const detail::CloudIndex index(surfaces.points, clearance);
  float d2 = 0.0f;
  std::erase_if(probes,
                [&](const Eigen::Vector3f& probe) { return index.nearestWithin(probe, d2) >= 0; });
  return probes;
}

}  // namespace

void standOn(ObjectModel& model, const std::optional<Eigen::Vector4f>& support,
             const SurfaceClusterParams& params) {
  model.support = support;
  model.standing_box.reset();
  if (support) model.standing_box = standingBox(model.surface, *support, params);
}

ObjectModel teachObjectModel(std::string name, const cv::Mat& depth_mm,
                             const CameraIntrinsics& intrinsics, const cv::Mat& object_mask,
                             const ObjectModelParams& params, const FlatFaces* frame_faces) {
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
  FlatFaces detected;
  if (frame_faces == nullptr) {
    detected = flatFacesOfPlanes(HoughPlaneDetector().detect(depth_mm, intrinsics), depth_mm,
                                 intrinsics, params.flat_faces);
    frame_faces = &detected;
  }
  standOn(model, supportBeneath(model.surface.points, *frame_faces, params.clusters),
          params.clusters);
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

}  // namespace shapesense
