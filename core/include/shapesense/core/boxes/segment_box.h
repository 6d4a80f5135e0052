#pragma once
// A 3D box from what an ROI covers (box mode 4): the operator marks an object with a rectangle,
// and the box is that of the frame's segments lying mostly inside the rectangle, minus the
// plane they stand on.
//
// Why not the ROI's depth readings (modes 1-3): a rectangle around an object also holds table
// and wall, and no statistic of the readings alone separates them from the object's own far
// side; those modes stop at about 0.9 of an object's visible points. The segmentation already
// separates them: it gives each planar face its own region and each curved object one region,
// apart from its support.
//
// Steps:
//   1. the ROI's segments: every segment with at least `min_inside_fraction` of its pixels
//      inside the ROI (a face of the object, wholly, including any pixels outside the ROI),
//      and the part inside the ROI of every segment with at least `min_clipped_fraction` inside
//      (an object the segmentation merged with a neighbour touching it); of those, the groups
//      joined without a depth step (continuousNeighbours) that hold such a face and are not
//      much smaller than the largest group: a patch of wall seen between two objects is not part
//      of either, nor is a sliver of the next object seen past this one's edge
//      (min_clipped_share_of_faces). A whole segment counts only near the ROI: the segmentation
//      may have joined a strip of something else to a face (the front edge of the table a tin
//      stands at), which must not stretch the box. When no
//      segment is covered, the object is part of a larger one (a book or a lid only a few depth
//      steps proud of the table is not parted from it): the part inside the ROI of the segment
//      holding most of the ROI's readings, standing on the plane region under most of that part;
//   2. their support: the plane region they stand on, as the object boxes find it
//      (supportPlaneBelow in object_boxes.h), unless more than a tenth of their points lie
//      below that plane, past its noise (an object beyond the table's far edge, seen over it,
//      or a shelf board or a box top at the object's mid-height: no support);
//   3. their points, minus the points on the support (within the sensor's noise of its plane:
//      a segment may have taken a strip of table along the object's foot) when at least a tenth
//      of them lie off it; for an object found inside a larger segment that is required (an
//      ROI on bare table holds no object);
//   4. the box: on a support, upright on it (its vertical axis along the plane's normal, its
//      footprint the smallest rectangle around the points cast onto the plane, from the plane
//      up to the highest point, reaching down to the plane when the object's foot is near it);
//      with no support, along the camera's axes. Each extent is taken between the
//      `trim_fraction` and 1 - `trim_fraction` quantiles of the points along that axis, so a
//      few flying pixels at the object's edges do not stretch it, and within the dense body of
//      the points along it (denseRange): stragglers past a gap wider than the sensor's noise at
//      the object's range (background pixels that joined a segment at its silhouette) do not
//      stretch it either.

#include <cstdint>
#include <variant>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/boxes/object_boxes.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/segmentation/segment_statistics.h"

namespace shapesense {

struct SegmentBoxParams {
  /// A segment is the ROI's when at least this share of its pixels lie inside the ROI.
  /// Default 0.5: the table or the wall behind the object lies mostly outside it.
  double min_inside_fraction = 0.5;
  /// A segment with at least this share inside (but less than min_inside_fraction) takes part
  /// with its pixels inside the ROI only. Default 0.03: the table, the floor or a wall an
  /// object stands before has far less of itself inside an ROI drawn around the object.
  double min_clipped_fraction = 0.03;
  /// A whole segment counts only within the ROI grown by this share of its width and height on
  /// each side: a loosely drawn ROI still gets all of the object's faces, while a strip the
  /// segmentation joined to a face (a table edge at a tin's foot) does not stretch the box far
  /// beyond it. Default 0.25.
  double whole_segment_reach = 0.25;
  /// Groups of covered segments joined without a depth step with fewer pixels than this share
  /// of the largest group are background. Default 0.1.
  double min_group_share = 0.1;
  /// A segment only clipped by the ROI, in a group with whole segments, joins it with at least
  /// this share of their pixels inside the ROI. Default 0.1 (chosen on the validation split and
  /// mosd_learn, docs/benchmarks.md).
  double min_clipped_share_of_faces = 0.1;
  /// Points within max(support_band_floor_m, support_band_steps sensor depth steps at their
  /// depth) of the support plane are the support's. Defaults 4 mm and 2 steps.
  double support_band_floor_m = 0.004;
  double support_band_steps = 2.0;
  /// The box reaches down to the support plane when the object's lowest point is at most this
  /// far above it (the object stands on it; its foot is hidden or was cut with the support).
  /// Default 0.05 m, chosen on the validation split and mosd_learn (docs/benchmarks.md, box
  /// mode 4).
  double max_foot_gap_m = 0.05;
  /// Share of the points ignored at each end of each axis (flying pixels). Default 0.002.
  double trim_fraction = 0.002;
  /// Along each axis, points past an empty stretch wider than max(max_gap_floor_m,
  /// max_gap_steps sensor depth steps at the points' median range) are left out, unless they
  /// hold at least min_cluster_share of the points (another object in the ROI). Defaults 3 cm,
  /// 3 steps and 0.2 (chosen on the validation split and mosd_learn, docs/benchmarks.md).
  double max_gap_floor_m = 0.03;
  double max_gap_steps = 3.0;
  double min_cluster_share = 0.2;
  /// The support rule (supportPlaneBelow) and the noise model of the band.
  ObjectBoxParams support{};
};

/// The box of the object marked by the ROI with corners p1, p2 (inclusive, any two opposite
/// corners) of `depth_mm`, from `segment_labels` (CV_16UC1, 0 = none; `segments` are its
/// statistics) and the frame's `planes` (see the file comment). The result's mode is
/// BoxMode::kSegments; its statistics are of the points' Z (near_m / far_m: the box's nearest
/// and farthest corner). Fails with kNoValidDepth when no segment lies mostly inside the ROI and
/// nothing in it rises off the surface it shows, or its segments have no depth reading, and as
/// estimateBox for an unsound request.
std::variant<BoxEstimate, BoxEstimationFailure> boxFromSegments(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics, cv::Point p1, cv::Point p2,
    const cv::Mat& segment_labels, const std::vector<SegmentStatistics>& segments,
    const PlaneDetection& planes, const SegmentBoxParams& params = {});

/// The object an ROI marks: steps 1-3 of boxFromSegments, without the rules that keep the box
/// tight (whole_segment_reach, groups only with faces, min_clipped_share_of_faces): the object
/// with what the segmentation joined to it. Teaching a recognition model from it measured better
/// than from the tight object (docs/benchmarks.md, box mode 4).
struct RoiObject {
  cv::Mat mask;  ///< CV_8UC1, the depth image's size: 255 on the object's pixels
  std::vector<Eigen::Vector3d> points;     ///< their camera-frame points, row by row
  const DetectedPlane* support = nullptr;  ///< the plane it stands on (in `planes`), if any
};

/// The object the ROI with corners p1, p2 marks (RoiObject; boxFromSegments says the arguments
/// and the failures). Its use: what to teach as an object (recognition).
std::variant<RoiObject, BoxEstimationFailure> objectUnderRoi(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics, cv::Point p1, cv::Point p2,
    const cv::Mat& segment_labels, const std::vector<SegmentStatistics>& segments,
    const PlaneDetection& planes, const SegmentBoxParams& params = {});

/// A segment an ROI covers (step 1 of boxFromSegments).
struct RoiSegment {
  std::uint16_t id = 0;
  bool whole = false;  ///< all its pixels belong to the object, not just those inside the ROI
  int pixels = 0;      ///< the pixels it contributes (with depth, for whole segments)
};

/// The segments of `segment_labels` that `roi` covers, wholly or clipped (step 1 of
/// boxFromSegments, before the continuity rule), sorted by id; shares are of the pixels with
/// depth, as the statistics count them.
std::vector<RoiSegment> segmentsUnderRoi(const cv::Mat& depth_mm, const cv::Mat& segment_labels,
                                         const std::vector<SegmentStatistics>& segments,
                                         const cv::Rect& roi, const SegmentBoxParams& params);

}  // namespace shapesense
