#pragma once
// The flat faces of an object and the convex edges where two of them meet, as a box's front
// and top do: pose hypotheses that need no interest points. Object matching
// (object_matching.h) lays each of a model's edges on each of the scene's of the same angle and
// no larger (and, for a model without an edge, each face on each scene face of its size) and
// lets the depth check judge the poses: where a box shows too few repeatable
// interest points for the features to propose its pose, its faces still do.
//  - An edge: the two normals fix the rotation, the two planes the object's place across the
//    edge, and the ends of the edge its place along it.
//  - A face alone (a box seen square on): its normal and its rectangle's sides fix the
//    rotation up to the rectangle's symmetry, its centre the place; it needs the whole face in
//    view.
//
// The faces come from a surface cloud (a model: the largest sets of points on one plane with
// normals that agree) or from a plane detection (a scene: its regions); the edges from the
// pairs of faces that come close to the line where their planes cross, each face lying behind
// the other's plane.

#include <array>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/recognition/surface_cloud.h"

namespace shapesense {

struct FlatFaceParams {
  /// Surface clouds: a face holds the points within max(face_distance_m, face_distance_steps
  /// sensor depth steps at its range) of its plane whose normals lie within face_normal_deg of
  /// its normal: a face taught at 2.5 m reads a centimetre of noise. Defaults 6 mm, 1 step,
  /// 15 deg.
  float face_distance_m = 0.006f;
  float face_distance_steps = 1.0f;
  float face_normal_deg = 15.0f;
  /// ...at least this share of the cloud's points, and at least 20. At most max_faces faces.
  /// Defaults 0.08, 4.
  float min_face_share = 0.08f;
  int max_faces = 4;
  /// Each plane detection's region is read on about this many points (every k-th pixel in
  /// both directions), and a surface cloud on at most this many for each face looked for
  /// (every k-th point). Default 1500.
  int max_face_points = 1500;
  /// Two faces meet at an edge when both have points within this distance of the line where
  /// their planes cross (m): a plane detection's regions stop short of a crease by a few
  /// pixels. Default 3 cm.
  float edge_reach_m = 0.03f;
  /// ...at least this many points each. Default 5.
  int min_edge_points = 5;
  /// ...their normals at least this far from parallel (deg). Default 25.
  float min_edge_angle_deg = 25.0f;
  /// ...and each face lies behind the other's plane by at least this on average (m): a convex
  /// edge, as an object's faces show it. Default 5 mm.
  float min_convex_depth_m = 0.005f;
  /// Sensor noise model for face_distance_steps.
  KinectNoiseModel noise{};
};

/// Points on one plane n.X + d = 0, the unit normal on the side the surface's normals face.
struct SurfaceFace {
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  float d = 0.0f;
  std::vector<Eigen::Vector3f> points;
};

/// A face as the smallest rectangle around its points on its plane: its centre, its in-plane
/// axes (along its sides, the longer side first) and its sides.
struct FaceRectangle {
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  std::array<Eigen::Vector3f, 2> axes{Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero()};
  std::array<float, 2> sides{};
};

/// Two faces meeting at a convex edge. The edge runs along `direction` = normals[0] x
/// normals[1] (normalised) through `line_point`; the faces' points near it span
/// [start, end] along it (from line_point), and each face runs `reach` from the line.
struct FaceEdge {
  std::array<Eigen::Vector3f, 2> normals{Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero()};
  Eigen::Vector3f line_point = Eigen::Vector3f::Zero();
  Eigen::Vector3f direction = Eigen::Vector3f::Zero();
  float start = 0.0f;
  float end = 0.0f;
  std::array<float, 2> reach{};
};

/// The faces of one surface (an object's, a scene's) as rectangles, and the edges between them.
struct FlatFaces {
  std::vector<FaceRectangle> faces;
  std::vector<FaceEdge> edges;
};

/// The largest planar faces of `surface` (normals as the surface's), largest first.
std::vector<SurfaceFace> facesOfSurface(const SurfaceCloud& surface,
                                        const FlatFaceParams& params = {});

/// The regions of `planes` as faces, read from `depth_mm` (CV_16UC1). None when the label
/// image does not match the depth image.
std::vector<SurfaceFace> facesOfPlanes(const PlaneDetection& planes, const cv::Mat& depth_mm,
                                       const CameraIntrinsics& intrinsics,
                                       const FlatFaceParams& params = {});

/// The pairs of `faces` that meet at a convex edge.
std::vector<FaceEdge> convexEdges(const std::vector<SurfaceFace>& faces,
                                  const FlatFaceParams& params = {});

/// The rectangle around `face`'s points.
FaceRectangle rectangleOf(const SurfaceFace& face);

/// The rectangles of `faces` and their convex edges.
FlatFaces flatFacesOf(const std::vector<SurfaceFace>& faces, const FlatFaceParams& params = {});

/// flatFacesOf the faces of `planes` (a frame's, read from `depth_mm`: SceneSurface::flatFaces).
FlatFaces flatFacesOfPlanes(const PlaneDetection& planes, const cv::Mat& depth_mm,
                            const CameraIntrinsics& intrinsics, const FlatFaceParams& params = {});

/// flatFacesOf the faces of `surface` (an object's: ObjectModel::flat_faces).
FlatFaces flatFacesOfSurface(const SurfaceCloud& surface, const FlatFaceParams& params = {});

/// The poses that carry `model`'s edge onto `scene`'s (scene_from_model): either face onto
/// either (when the angles between the normals agree within `angle_tolerance_deg`), and
/// either end of the edge onto the same end, where the scene's edge is no longer and its faces
/// run no farther from it than the model's by more than `size_slack_m`. At most four.
std::vector<Eigen::Isometry3f> edgeAlignedPoses(const FaceEdge& model, const FaceEdge& scene,
                                                float angle_tolerance_deg, float size_slack_m);

/// The poses that lay `model`'s face on `scene`'s, centre on centre, where their sides agree
/// within `size_slack_m`: each turn of the rectangle onto itself (two, or four for a square
/// within the slack).
std::vector<Eigen::Isometry3f> faceAlignedPoses(const FaceRectangle& model,
                                                const FaceRectangle& scene, float size_slack_m);

}  // namespace shapesense
