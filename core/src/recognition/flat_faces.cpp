#include "shapesense/core/recognition/flat_faces.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "cloud_index.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {
namespace {

constexpr int kMinFacePoints = 20;
// The edge's ends and the faces' reach: a few flying pixels and stray points stay out.
constexpr double kEndQuantile = 0.03;

float cosDeg(float deg) { return static_cast<float>(std::cos(degToRad(deg))); }

// The points of `surface` among `candidates` within `distance` of the plane (normal, d) with
// normals that agree.
std::vector<std::uint32_t> onPlane(const SurfaceCloud& surface,
                                   const std::vector<std::uint32_t>& candidates,
                                   const Eigen::Vector3f& normal, float d, float distance,
                                   const FlatFaceParams& params) {
  const float min_cos = cosDeg(params.face_normal_deg);
  std::vector<std::uint32_t> out;
  for (std::uint32_t i : candidates)
    if (std::abs(normal.dot(surface.points[i]) + d) <= distance &&
        normal.dot(surface.normals[i]) >= min_cos)
      out.push_back(i);
  return out;
}

// How far from its plane a face's points may lie, at the range of `p`.
float faceDistance(const Eigen::Vector3f& p, const FlatFaceParams& params) {
  return std::max(params.face_distance_m,
                  params.face_distance_steps * static_cast<float>(params.noise.depthStep(p.z())));
}

// The largest face among `remaining`: the tangent plane of an evenly spread choice of seed
// points that holds most of them, refitted to those it holds. Empty when none holds
// `min_points`.
SurfaceFace largestFace(const SurfaceCloud& surface, const std::vector<std::uint32_t>& remaining,
                        std::size_t min_points, const FlatFaceParams& params,
                        std::vector<std::uint32_t>& taken) {
  constexpr std::size_t kSeeds = 128;
  const std::size_t stride = std::max<std::size_t>(1, remaining.size() / kSeeds);
  std::vector<std::uint32_t> best;
  for (std::size_t s = 0; s < remaining.size(); s += stride) {
    const std::uint32_t seed = remaining[s];
    const Eigen::Vector3f& n = surface.normals[seed];
    std::vector<std::uint32_t> held = onPlane(surface, remaining, n, -n.dot(surface.points[seed]),
                                              faceDistance(surface.points[seed], params), params);
    if (held.size() > best.size()) best = std::move(held);
  }
  if (best.size() < min_points) return {};
  PlaneMoments moments;
  Eigen::Vector3f mean_normal = Eigen::Vector3f::Zero();
  for (std::uint32_t i : best) {
    moments.add(surface.points[i].cast<double>());
    mean_normal += surface.normals[i];
  }
  const PlaneFit fit = moments.fit();
  if (!fit.valid) return {};
  SurfaceFace face;
  face.normal = fit.normal.cast<float>();
  if (face.normal.dot(mean_normal) < 0.0f) face.normal = -face.normal;
  face.d = -face.normal.dot(fit.centroid.cast<float>());
  taken = onPlane(surface, remaining, face.normal, face.d,
                  faceDistance(fit.centroid.cast<float>(), params), params);
  if (taken.size() < min_points) return {};
  for (std::uint32_t i : taken) face.points.push_back(surface.points[i]);
  return face;
}

float distanceToLine(const Eigen::Vector3f& p, const Eigen::Vector3f& line_point,
                     const Eigen::Vector3f& direction) {
  const Eigen::Vector3f offset = p - line_point;
  return (offset - offset.dot(direction) * direction).norm();
}

// Mean of n.X + d over `points`: negative when they lie behind the plane.
float meanSignedDistance(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& normal,
                         float d) {
  double sum = 0.0;
  for (const Eigen::Vector3f& p : points) sum += normal.dot(p) + d;
  return static_cast<float>(sum / static_cast<double>(points.size()));
}

Eigen::AlignedBox3f boundsOf(const std::vector<Eigen::Vector3f>& points) {
  Eigen::AlignedBox3f out;
  for (const Eigen::Vector3f& p : points) out.extend(p);
  return out;
}

// The edge of faces a and b, if they meet at a convex one.
std::optional<FaceEdge> edgeOf(const SurfaceFace& a, const SurfaceFace& b,
                               const FlatFaceParams& params) {
  if (a.points.empty() || b.points.empty()) return std::nullopt;
  const Eigen::Vector3f cross = a.normal.cross(b.normal);
  // Nearly parallel faces cross along no line worth the name (and at 0 deg, none at all).
  if (cross.norm() < std::max(1e-3, std::sin(degToRad(params.min_edge_angle_deg))))
    return std::nullopt;
  if (meanSignedDistance(a.points, b.normal, b.d) > -params.min_convex_depth_m ||
      meanSignedDistance(b.points, a.normal, a.d) > -params.min_convex_depth_m)
    return std::nullopt;
  FaceEdge edge;
  edge.normals = {a.normal, b.normal};
  edge.direction = cross.normalized();
  Eigen::Matrix3f planes;
  planes << a.normal.transpose(), b.normal.transpose(), edge.direction.transpose();
  edge.line_point = planes.inverse() * Eigen::Vector3f(-a.d, -b.d, 0.0f);
  std::vector<double> along;
  const std::array<const SurfaceFace*, 2> faces = {&a, &b};
  for (std::size_t f = 0; f < 2; ++f) {
    std::vector<double> away;
    away.reserve(faces[f]->points.size());
    int near = 0;
    for (const Eigen::Vector3f& p : faces[f]->points) {
      const float distance = distanceToLine(p, edge.line_point, edge.direction);
      away.push_back(distance);
      if (distance > params.edge_reach_m) continue;
      ++near;
      along.push_back((p - edge.line_point).dot(edge.direction));
    }
    if (near < std::max(1, params.min_edge_points)) return std::nullopt;
    edge.reach[f] = static_cast<float>(quantile(away, 1.0 - kEndQuantile));
  }
  const auto [start, end] = trimmedRange(along, kEndQuantile);
  edge.start = static_cast<float>(start);
  edge.end = static_cast<float>(end);
  return edge;
}

// An orthonormal frame with `first` as its first axis and `second` in the plane of its first
// two.
Eigen::Matrix3f frameOf(const Eigen::Vector3f& first, const Eigen::Vector3f& second) {
  const Eigen::Vector3f y = (second - second.dot(first) * first).normalized();
  Eigen::Matrix3f out;
  out << first, y, first.cross(y);
  return out;
}

}  // namespace

std::vector<SurfaceFace> facesOfSurface(const SurfaceCloud& surface, const FlatFaceParams& params) {
  // Every k-th point, at most max_face_points for each face looked for: a model's surface is
  // thinned to about that already, a cloud from a file may hold many more.
  const std::size_t stride = detail::thinningStep(
      surface.size(), std::max(1, params.max_face_points) * std::max(1, params.max_faces));
  std::vector<std::uint32_t> remaining;
  for (std::size_t i = 0; i < surface.size(); i += stride)
    remaining.push_back(static_cast<std::uint32_t>(i));
  const std::size_t min_points = std::max<std::size_t>(
      kMinFacePoints,
      static_cast<std::size_t>(params.min_face_share * static_cast<float>(remaining.size())));
  std::vector<SurfaceFace> out;
  std::vector<std::uint32_t> taken;
  while (static_cast<int>(out.size()) < params.max_faces && remaining.size() >= min_points) {
    SurfaceFace face = largestFace(surface, remaining, min_points, params, taken);
    if (face.points.empty()) break;
    out.push_back(std::move(face));
    std::vector<std::uint32_t> rest;
    std::set_difference(remaining.begin(), remaining.end(), taken.begin(), taken.end(),
                        std::back_inserter(rest));
    remaining = std::move(rest);
  }
  return out;
}

std::vector<SurfaceFace> facesOfPlanes(const PlaneDetection& planes, const cv::Mat& depth_mm,
                                       const CameraIntrinsics& intrinsics,
                                       const FlatFaceParams& params) {
  std::vector<SurfaceFace> out;
  if (planes.labels.size() != depth_mm.size() || planes.labels.type() != CV_16UC1 ||
      depth_mm.type() != CV_16UC1)
    return out;
  const cv::Rect image(0, 0, depth_mm.cols, depth_mm.rows);
  for (const DetectedPlane& plane : planes.planes) {
    const auto budget = static_cast<double>(std::max(1, params.max_face_points));
    const int step = std::max(
        1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(plane.inliers) / budget))));
    SurfaceFace face;
    face.normal = plane.normal.cast<float>();
    face.d = static_cast<float>(plane.d);
    const cv::Rect box = plane.box & image;
    for (int v = box.y; v < box.y + box.height; v += step) {
      const auto* label = planes.labels.ptr<std::uint16_t>(v);
      const auto* depth = depth_mm.ptr<std::uint16_t>(v);
      for (int u = box.x; u < box.x + box.width; u += step) {
        if (label[u] != plane.id || depth[u] == 0) continue;
        face.points.push_back(intrinsics.backproject(u, v, 1e-3 * depth[u]).cast<float>());
      }
    }
    if (face.points.size() >= static_cast<std::size_t>(params.min_edge_points))
      out.push_back(std::move(face));
  }
  return out;
}

std::vector<FaceEdge> convexEdges(const std::vector<SurfaceFace>& faces,
                                  const FlatFaceParams& params) {
  std::vector<Eigen::AlignedBox3f> bounds;
  for (const SurfaceFace& face : faces) bounds.push_back(boundsOf(face.points));
  const Eigen::Vector3f margin = Eigen::Vector3f::Constant(params.edge_reach_m);
  std::vector<FaceEdge> out;
  for (std::size_t i = 0; i < faces.size(); ++i)
    for (std::size_t j = i + 1; j < faces.size(); ++j) {
      // Faces whose bounds stay farther apart than the reach have no points near one line.
      const Eigen::AlignedBox3f grown(bounds[i].min() - margin, bounds[i].max() + margin);
      if (!grown.intersects(bounds[j])) continue;
      if (auto edge = edgeOf(faces[i], faces[j], params)) out.push_back(*edge);
    }
  return out;
}

FaceRectangle rectangleOf(const SurfaceFace& face) {
  FaceRectangle out;
  out.normal = face.normal;
  if (face.points.empty()) return out;
  // The points in a frame on the plane, and the smallest rectangle around them: its sides
  // follow a box face's edges where the points' principal axes of a nearly square face need
  // not.
  const Eigen::Vector3f origin = face.points.front();
  const Eigen::Vector3f u = face.normal.unitOrthogonal();
  const Eigen::Vector3f v = face.normal.cross(u);
  std::vector<cv::Point2f> flat;
  flat.reserve(face.points.size());
  for (const Eigen::Vector3f& p : face.points)
    flat.emplace_back(u.dot(p - origin), v.dot(p - origin));
  const cv::RotatedRect rectangle = cv::minAreaRect(flat);
  const auto angle = static_cast<float>(degToRad(rectangle.angle));
  const Eigen::Vector3f width_axis = std::cos(angle) * u + std::sin(angle) * v;
  const Eigen::Vector3f height_axis = face.normal.cross(width_axis);
  out.centre = origin + rectangle.center.x * u + rectangle.center.y * v;
  // Distances along the plane's normal: the rectangle's centre lies on the plane.
  out.centre -= (face.normal.dot(out.centre) + face.d) * face.normal;
  if (rectangle.size.width >= rectangle.size.height) {
    out.axes = {width_axis, height_axis};
    out.sides = {rectangle.size.width, rectangle.size.height};
  } else {
    out.axes = {height_axis, -width_axis};
    out.sides = {rectangle.size.height, rectangle.size.width};
  }
  return out;
}

FlatFaces flatFacesOfPlanes(const PlaneDetection& planes, const cv::Mat& depth_mm,
                            const CameraIntrinsics& intrinsics, const FlatFaceParams& params) {
  return flatFacesOf(facesOfPlanes(planes, depth_mm, intrinsics, params), params);
}

FlatFaces flatFacesOfSurface(const SurfaceCloud& surface, const FlatFaceParams& params) {
  return flatFacesOf(facesOfSurface(surface, params), params);
}

FlatFaces flatFacesOf(const std::vector<SurfaceFace>& faces, const FlatFaceParams& params) {
  FlatFaces out;
  for (const SurfaceFace& face : faces) out.faces.push_back(rectangleOf(face));
  out.edges = convexEdges(faces, params);
  return out;
}

std::vector<Eigen::Isometry3f> edgeAlignedPoses(const FaceEdge& model, const FaceEdge& scene,
                                                float angle_tolerance_deg, float size_slack_m) {
  const float model_angle =
      std::acos(std::clamp(model.normals[0].dot(model.normals[1]), -1.f, 1.f));
  const float scene_angle =
      std::acos(std::clamp(scene.normals[0].dot(scene.normals[1]), -1.f, 1.f));
  if (std::abs(model_angle - scene_angle) > degToRad(angle_tolerance_deg)) return {};
  std::vector<Eigen::Isometry3f> out;
  const Eigen::Matrix3f model_frame = frameOf(model.normals[0], model.normals[1]);
  for (const bool swapped : {false, true}) {
    // The scene's faces in the order they take the model's; with them swapped the edge runs
    // the other way.
    const std::size_t first = swapped ? 1 : 0;
    const float sign = swapped ? -1.0f : 1.0f;
    const float start = swapped ? -scene.end : scene.start;
    const float end = swapped ? -scene.start : scene.end;
    if (end - start > model.end - model.start + size_slack_m ||
        scene.reach[first] > model.reach[0] + size_slack_m ||
        scene.reach[1 - first] > model.reach[1] + size_slack_m)
      continue;
    Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
    pose.linear() =
        frameOf(scene.normals[first], scene.normals[1 - first]) * model_frame.transpose();
    const Eigen::Vector3f direction = sign * scene.direction;
    const Eigen::Vector3f lines = scene.line_point - pose.linear() * model.line_point;
    const float shift_at_start = start - model.start;
    const float shift_at_end = end - model.end;
    pose.translation() = lines + shift_at_start * direction;
    out.push_back(pose);
    // Ends that agree give one pose.
    constexpr float kSameShiftM = 0.005f;
    if (std::abs(shift_at_end - shift_at_start) < kSameShiftM) continue;
    pose.translation() = lines + shift_at_end * direction;
    out.push_back(pose);
  }
  return out;
}

std::vector<Eigen::Isometry3f> faceAlignedPoses(const FaceRectangle& model,
                                                const FaceRectangle& scene, float size_slack_m) {
  const auto fits = [&](float a, float b) {
    return std::abs(scene.sides[0] - a) <= size_slack_m &&
           std::abs(scene.sides[1] - b) <= size_slack_m;
  };
  // The scene's in-plane axes the model's first axis may turn onto, with its second following
  // (normal x first).
  std::vector<Eigen::Vector3f> firsts;
  if (fits(model.sides[0], model.sides[1])) {
    firsts.push_back(scene.axes[0]);
    firsts.push_back(-scene.axes[0]);
  }
  if (fits(model.sides[1], model.sides[0])) {
    firsts.push_back(scene.axes[1]);
    firsts.push_back(-scene.axes[1]);
  }
  Eigen::Matrix3f model_frame;
  model_frame << model.axes[0], model.axes[1], model.normal;
  std::vector<Eigen::Isometry3f> out;
  for (const Eigen::Vector3f& first : firsts) {
    Eigen::Matrix3f scene_frame;
    scene_frame << first, scene.normal.cross(first), scene.normal;
    Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
    pose.linear() = scene_frame * model_frame.transpose();
    pose.translation() = scene.centre - pose.linear() * model.centre;
    out.push_back(pose);
  }
  return out;
}

}  // namespace shapesense
