#pragma once
// 3D boxes of the objects the detectors found, without anyone drawing a ROI: every segment that
// stands on a detected plane (a thing on a table or on the floor) gets the box estimateBox gives
// for the segment's 2D bounds.
//
// "Stands on a plane" is decided in the image, for a camera that is roughly upright (a robot
// head): below the segment's lowest pixel in a column, within `support_search_px`, lies a pixel
// of some plane region; the plane most columns reach is the support, and it must be reached by
// at least `min_support_fraction` of the segment's columns. A plane the segment's centroid does
// not rise above by `min_height_m` is something in front of its foot (the face of another box),
// not a support: its columns are left out of the count. The segment must not be mostly the
// support plane itself.
// Walls are not objects: segments larger than `max_image_fraction` or whose box exceeds
// `max_size_m` are left out.

#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/segmentation/segment_statistics.h"

namespace shapesense {

struct ObjectBoxParams {
  /// Segments smaller than this fraction of the image are noise. Default 0.0005 (154 px of VGA).
  double min_image_fraction = 0.0005;
  /// Larger segments are structure (walls, floor, table). Default 0.15.
  double max_image_fraction = 0.15;
  /// How far below a segment's bottom edge (pixels) the support plane is looked for. Default 8.
  int support_search_px = 8;
  /// Fraction of the segment's columns that must reach the support plane. Default 0.3.
  double min_support_fraction = 0.3;
  /// A segment with more of its pixels on the support plane than this is part of it. Default 0.5.
  double max_support_overlap = 0.5;
  /// Centroid at least this far (m) in front of the support plane. Default 0.01.
  double min_height_m = 0.01;
  /// Boxes with any side longer than this (m) are not objects. Default 1.0.
  double max_size_m = 1.0;
  /// Two touching segments are neighbours (faces of one object) where their depths differ by at
  /// most continuity_floor_m + continuity_noise_steps sensor depth steps at the nearer of the
  /// two pixels (estimation.noise); an object and the wall behind it only meet across a larger
  /// step. Defaults 0.01 m and 3 steps.
  double continuity_floor_m = 0.01;
  double continuity_noise_steps = 3.0;
  /// How the segment's bounds are read (the segment's silhouette: the ROI contains the box).
  BoxMode mode = BoxMode::kAxisAlignedContained;
  BoxEstimationParams estimation{};
};

struct ObjectBox {
  std::uint16_t segment_id = 0;        ///< the segment the box was made from
  std::uint16_t support_plane_id = 0;  ///< the plane region it stands on
  cv::Rect roi;                        ///< the segment's 2D bounds, used as ROI
  BoxEstimate box;
};

/// Boxes of the segments of `segment_labels` that stand on a region of `planes` (see the file
/// comment). `segments` are the statistics of `segment_labels`.
std::vector<ObjectBox> boxesOfObjectsOnPlanes(const cv::Mat& depth_mm,
                                              const CameraIntrinsics& intrinsics,
                                              const cv::Mat& segment_labels,
                                              const std::vector<SegmentStatistics>& segments,
                                              const PlaneDetection& planes,
                                              const ObjectBoxParams& params = {});

/// Which segments of `labels` touch which across depth-continuous pixel pairs only (the
/// continuity rule of ObjectBoxParams: an object's faces touch; an object and the wall behind it
/// only meet across a depth step), looking at the pixel pairs inside `within` (empty = the
/// whole image). Symmetric: b is in result[a] exactly when a is in result[b].
std::map<std::uint16_t, std::set<std::uint16_t>> continuousNeighbours(
    const cv::Mat& labels, const cv::Mat& depth_mm, const ObjectBoxParams& params = {},
    const cv::Rect& within = {});

/// The plane region that the segments `segment_ids` of `segment_labels` stand on, taken
/// together (the faces of one object), by the rule of the file comment; nullptr when none.
/// The result points into `planes`.
const DetectedPlane* supportPlaneBelow(const cv::Mat& depth_mm, const cv::Mat& segment_labels,
                                       const std::vector<SegmentStatistics>& segments,
                                       const PlaneDetection& planes,
                                       const std::vector<std::uint16_t>& segment_ids,
                                       const ObjectBoxParams& params = {});

}  // namespace shapesense
