#pragma once
// Local shape descriptors by projection onto local planes (D4.6.2 section 3.1): the surface
// around an interest point is expressed in a local frame whose z axis is the normal of the
// local plane, projected onto that plane and rasterised into a small height image, so that the
// shape is compared as an image. Works on any SurfaceCloud: a depth frame or a point cloud.
//
// Steps (detectShapeFeatures):
//   1. interest points: where the normals within `keypoint_radius_m` spread (edges, corners,
//      curved surfaces; zero on a plane), kept when they are the strongest within
//      `keypoint_spacing_m` (non-maximum suppression);
//   2. repeatable local frames at each, from the points within `support_radius_m`: z (the
//      local plane's normal) the mean of their normals, turned to face the viewpoint; x each
//      direction in the local plane their normals lean towards most (the peaks of a histogram
//      of the normals' parts in the plane: an edge gives two, a corner three), or, where they
//      lean nowhere, towards their centroid; both hold for another view that shows the same
//      surface around the point. One feature per frame: the features of one interest point
//      follow each other in the output, with the same position;
//   3. the height image: those points in the local frame, their mean height over the plane in
//      each cell of an `height_image_size`^2 grid over [-R, R]^2 (cells no point falls in take
//      their filled neighbours' mean);
//   4. the descriptor: the height image pooled to kShapeDescriptorCells^2 cells, in units of R.
// The descriptor is metric (no scale normalisation): depth sensors measure size, and an object
// of another size is another object.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/recognition/surface_cloud.h"

namespace shapesense {

inline constexpr int kShapeDescriptorCells = 8;
inline constexpr int kShapeDescriptorSize = kShapeDescriptorCells * kShapeDescriptorCells;

struct ShapeFeatureParams {
  /// Radius of the neighbourhood projected onto the local plane (m). Default 3.5 cm: a mug's
  /// handle or a box corner with a few centimetres of each face.
  float support_radius_m = 0.035f;
  /// Side of the height image in cells before pooling. Default 16 (4.4 mm cells at the default
  /// radius, about one voxel).
  int height_image_size = 16;
  /// Radius over which the normals' spread makes the interest response (m). Default 1.5 cm.
  float keypoint_radius_m = 0.015f;
  /// No two interest points closer than this (m). Default 1.2 cm.
  float keypoint_spacing_m = 0.012f;
  /// Smallest interest response: 1 - the largest eigenvalue of the normals' mean outer product
  /// plus the smallest one (a plane 0, a right-angled edge 0.5, a corner 1). Default 0.06.
  float min_response = 0.06f;
  /// Smallest share of the height image's cells that hold a point; fewer means the point sits
  /// on a silhouette with most of its neighbourhood unseen. Default 0.35.
  float min_filled_share = 0.35f;
  /// A local frame's x axis is each direction the support's normals lean towards with at
  /// least this share of the strongest direction's weight (see detectShapeFeatures). Default 0.8.
  float orientation_peak_ratio = 0.8f;
  /// At most this many frames (features) per interest point, the strongest first. 0 = no
  /// limit. Default 3 (the faces of a corner).
  int max_orientations = 3;
  /// At most this many features, the strongest responses first. 0 = no limit. Default 0.
  int max_features = 0;
};

struct ShapeFeature {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();
  /// Columns: the local frame's x, y and z axes (z = the local plane's normal, facing the
  /// viewpoint). Maps local coordinates to the cloud's frame.
  Eigen::Matrix3f frame = Eigen::Matrix3f::Identity();
  float response = 0.0f;
  std::array<float, kShapeDescriptorSize> descriptor{};
};

/// The interest points of `surface` and their descriptors (see the file comment). When
/// `may_hold_keypoint` is not empty (one flag per point), only flagged points become interest
/// points, while every point still counts in their neighbourhoods: an object's features are
/// described with the table it stands on, as they will be seen in a scene.
std::vector<ShapeFeature> detectShapeFeatures(
    const SurfaceCloud& surface, const ShapeFeatureParams& params = {},
    const Eigen::Vector3f& viewpoint = Eigen::Vector3f::Zero(),
    const std::vector<std::uint8_t>& may_hold_keypoint = {});

/// Squared Euclidean distance between two descriptors.
float descriptorDistance2(const ShapeFeature& a, const ShapeFeature& b);

}  // namespace shapesense
