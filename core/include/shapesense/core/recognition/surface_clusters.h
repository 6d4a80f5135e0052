#pragma once
// The surface of a scene off its large planes (a table, the floor, a wall), in connected
// clusters: the things standing on them, each as a box. A model's box laid on the box of a
// cluster of about its size gives poses that need neither interest points nor flat faces, as
// for a bowl's smooth surface; the depth check (object_matching.h) judges them.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "shapesense/core/recognition/flat_faces.h"
#include "shapesense/core/recognition/oriented_box.h"
#include "shapesense/core/recognition/surface_cloud.h"

namespace shapesense {

struct SurfaceClusterParams {
  /// A scene face (flat_faces.h) whose longer side is at least this supports things (m); the
  /// largest objects taught are 60 cm. Default 50 cm.
  float min_support_side_m = 0.5f;
  /// A point lies on a support when it is within support_distance_m of its plane and inside
  /// its rectangle grown by support_margin_m (a plane detection's region stops short of its
  /// edges by a few pixels). Defaults 1.5 cm, 2 cm.
  float support_distance_m = 0.015f;
  float support_margin_m = 0.02f;
  /// Points this close to each other are in one cluster (m): past the 5 mm voxels of the
  /// surface (surface_cloud.h) and a missing reading. Default 1.2 cm.
  float link_distance_m = 0.012f;
  /// Clusters with fewer points are left out. Default 100.
  int min_points = 100;
};

/// The clusters of `surface` off the supports among `faces` (the scene's), each as its
/// principalBox, in no particular order.
std::vector<OrientedBox> surfaceClusters(const SurfaceCloud& surface, const FlatFaces& faces,
                                         const SurfaceClusterParams& params = {});

/// Whether two boxes are of about one size: each of their sizes, smallest to largest, apart by
/// at most `slack` times the first box's plus 2 cm. A cluster's box measures what its view
/// shows, which another view of the same object shows more or less of.
bool similarBoxSizes(const OrientedBox& model, const OrientedBox& cluster, float slack);

/// The poses (cluster from model) that lay `model`'s box on `cluster`'s, centre on centre and
/// axes on axes: the 24 turns that carry one right-handed frame's axes onto another's, either
/// way round. Which one is right only the depth can tell.
std::vector<Eigen::Isometry3f> boxAlignedPoses(const OrientedBox& model,
                                               const OrientedBox& cluster);

}  // namespace shapesense
