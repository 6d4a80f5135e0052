#pragma once
// A taught object: its surface and shape features from one view (a depth frame and the
// object's pixels) or from a point cloud, kept in the model's own frame (for a taught view, the
// camera frame of the frame it was taught from).

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/recognition/flat_faces.h"
#include "shapesense/core/recognition/oriented_box.h"
#include "shapesense/core/recognition/shape_features.h"
#include "shapesense/core/recognition/surface_cloud.h"
#include "shapesense/core/recognition/surface_clusters.h"

namespace shapesense {

struct ObjectModelParams {
  SurfaceCloudParams surface{};
  ShapeFeatureParams features{};
  /// The surface within this distance of the object's points is its context (m): features are
  /// described with what lies around them, as a scene will show them. Default: the features'
  /// support radius.
  float context_margin_m = 0.035f;
  /// The object's surface is thinned to at most this many points for pose refinement and
  /// scoring (every k-th point). Default 2000.
  int max_surface_points = 2000;
  /// Fewest features a model needs to be found again. Default 6.
  int min_features = 6;
  /// Outline probes lie this many pixels beyond the outline (past its flying pixels), and at
  /// least this far (m): nearer, another view's glimpse of the object's own side, which runs
  /// back from the outline, would read as surface at the probe's depth; farther, the model
  /// fits a larger object's corner with room to spare. Defaults 3 px, 1.25 cm (chosen on the
  /// validation split, docs/benchmarks.md).
  int outline_probe_offset_px = 3;
  float outline_probe_offset_m = 0.0125f;
  /// Probes within this distance of a surface the taught view shows are left out (m): beside
  /// the object's foot a probe hangs just over what it stands on, which another view reads at
  /// the probe's depth. Default 1 cm.
  float outline_probe_clearance_m = 0.01f;
  /// At most this many outline probes (every k-th). Default 400.
  int max_outline_probes = 400;
  /// Flat faces and their edges, of the model and of the scenes it is looked for in.
  FlatFaceParams flat_faces{};
  /// The clusters of the scenes a model is looked for in (SceneSurface::clusters).
  SurfaceClusterParams clusters{};
};

struct ObjectModel {
  std::string name;
  SurfaceCloud surface;                ///< the object alone, model frame
  std::vector<ShapeFeature> features;  ///< interest points on the object, model frame
  OrientedBox box;                     ///< around `surface`, along its principal axes
  /// Points just beyond the object's outline where the taught view shows that the object
  /// ends: on a face's extension past its edge where the view sees no such surface there
  /// (background behind, or what the object stands on in front), and beside a silhouette
  /// where it sees background. If a scene shows surface there, at the probe's depth, what
  /// matched is part of something larger (a corner of a bigger box fits a small box's
  /// corner). Empty for models from a point cloud.
  std::vector<Eigen::Vector3f> outline_probes;
  /// The flat faces of `surface` and their convex edges (flat_faces.h): poses for objects
  /// whose interest points are too few. Made from `surface` whenever a model is taught or
  /// loaded.
  FlatFaces flat_faces;
  /// The plane the object stood on in the taught view (supportBeneath: n.X + d = 0, model
  /// frame), and the object's standingBox on it: a scene's cluster standing the same way gives
  /// its pose with the box's sides on the cluster's. None for models from a point cloud, or
  /// where the taught view showed no support beneath the object.
  std::optional<Eigen::Vector4f> support;
  std::optional<OrientedBox> standing_box;
};

/// The model of the object whose pixels are non-zero in `object_mask` (CV_8UC1, the depth
/// image's size), taught from `depth_mm` (CV_16UC1 mm). The frame's flat faces give the support
/// it stands on: `frame_faces` where the caller has them (SceneSurface::flatFaces of this
/// frame), else from the frame's planes, detected here. Throws std::invalid_argument when the
/// object has too little surface or too few features to be found again (the message says which).
ObjectModel teachObjectModel(std::string name, const cv::Mat& depth_mm,
                             const CameraIntrinsics& intrinsics, const cv::Mat& object_mask,
                             const ObjectModelParams& params = {},
                             const FlatFaces* frame_faces = nullptr);

/// Sets `model`'s support, and its standing box on it (none when `support` is none).
void standOn(ObjectModel& model, const std::optional<Eigen::Vector4f>& support,
             const SurfaceClusterParams& params = {});

/// The model of an object given as a surface of its own (a point cloud file), seen from
/// `viewpoint`. Throws std::invalid_argument as teachObjectModel.
ObjectModel objectModelFromSurface(std::string name, const SurfaceCloud& object,
                                   const Eigen::Vector3f& viewpoint = Eigen::Vector3f::Zero(),
                                   const ObjectModelParams& params = {});

}  // namespace shapesense
