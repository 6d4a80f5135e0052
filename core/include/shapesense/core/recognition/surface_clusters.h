#pragma once
// The surface of a scene off its large planes (a table, the floor, a wall), in connected
// clusters: the things standing on them, each as a box. A model's box laid on the box of a
// cluster of about its size gives poses that need neither interest points nor flat faces, as
// for a bowl's smooth surface; the depth check (object_matching.h) judges them.

#include <optional>
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
  /// A cluster stands on a support when its points lie on the support's side of it, with 1%
  /// of them (its foot) at most this far above it and over its rectangle (grown by the
  /// margin). Default 4 cm: the points within support_distance_m are the support's, and the
  /// foot of a box seen from above shows little more than that.
  float standing_reach_m = 0.04f;
  /// A standing box is taken around the points whose normal lies within this angle of the
  /// line of sight: past it lie flying pixels between an outline and the background, which
  /// turn the box. Default 75 deg.
  float max_view_angle_deg = 75.0f;
  /// ...and its sides end where, along an axis, the points thin out past a gap of this much
  /// (denseRange): a trail of flying pixels beyond a gap does not count. Default 2 cm.
  float standing_box_gap_m = 0.02f;
};

/// A scene's cluster of surface off its supports.
struct SurfaceCluster {
  OrientedBox box;  ///< its principalBox
  /// Its standingBox on the support it stands on (supportBeneath); none where it stands on none.
  std::optional<OrientedBox> standing_box;
};

/// The clusters of `surface` off the supports among `faces` (the scene's), in no particular
/// order.
std::vector<SurfaceCluster> surfaceClusters(const SurfaceCloud& surface, const FlatFaces& faces,
                                            const SurfaceClusterParams& params = {});

/// The box of `surface` (seen from the origin) standing on the plane `support` (n.X + d = 0,
/// unit n on the surface's side): its third axis is n and its bottom face lies in the plane.
/// Its first two axes lie along the faces of `surface` that stand upright (their normals
/// agree on a turn about n, up to quarter turns), or where none do, along the sides of the
/// smallest rectangle around the surface seen along n; along each axis it spans the points'
/// dense range (standing_box_gap_m). Only the points whose normal lies within
/// max_view_angle_deg of the line of sight count. A box's sides come out this way from
/// a view of a few of its faces, where the principal axes of what the view shows rarely lie
/// along them.
OrientedBox standingBox(const SurfaceCloud& surface, const Eigen::Vector4f& support,
                        const SurfaceClusterParams& params = {});

/// The plane (n.X + d = 0, n on the points' side) of the support among `faces` that `points`
/// stand on, as SurfaceClusterParams::standing_reach_m says; of several, the one under most of
/// their foot. None when they stand on none.
std::optional<Eigen::Vector4f> supportBeneath(const std::vector<Eigen::Vector3f>& points,
                                              const FlatFaces& faces,
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

/// Whether two standing boxes (standingBox) are of about one size: their heights, and the
/// sides of their footprints, shorter with shorter, as similarBoxSizes.
bool similarStandingSizes(const OrientedBox& model, const OrientedBox& cluster, float slack);

/// The poses (cluster from model) that stand `model`'s standing box on `cluster`'s: bottom
/// face centred on bottom face, third axis on third axis, turned about it by the four quarter
/// turns that carry the footprint's sides onto the cluster's.
std::vector<Eigen::Isometry3f> standingPoses(const OrientedBox& model, const OrientedBox& cluster);

}  // namespace shapesense
