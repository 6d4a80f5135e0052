#pragma once
// Scoring of 3D boxes against the points an object shows: how many of them a box holds, and
// how much bigger the box is than those points need. Used for EstimateBox's modes on synthetic
// truth objects and on the labelled real OSD objects, with the object's own image bounds as the
// ROI an operator would draw.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/segment_eval.h"

namespace shapesense::eval {

/// Volume (m^3) of the camera-axis-aligned box around `points` (the box "of those points").
double pointsBoxVolume(const std::vector<Eigen::Vector3d>& points);

/// Boxes of one mode over many objects.
struct BoxModeScore {
  int objects = 0;
  int failed = 0;                    ///< no box (an error status)
  std::vector<double> coverage;      ///< per boxed object: share of its points inside the box
  std::vector<double> volume_ratio;  ///< per boxed object: box volume / pointsBoxVolume
  /// Scores one object's box (or its absence) against the object's visible points.
  void add(const BoxCorners* box, const std::vector<Eigen::Vector3d>& points);
  void add(const BoxModeScore& other);
  /// Mean share of the objects' points inside their boxes, a failed box counting 0.
  double meanCoverage() const;
  /// Share of the objects whose own box holds at least `min_coverage` of their points and is at
  /// most `max_volume_ratio` times the box of those points (a failed box meets neither).
  double shareMeeting(double min_coverage, double max_volume_ratio) const;
};

/// Truth objects an operator would box: not room structure, the table or a shelf unit, with at
/// least `min_pixels` labelled pixels and an image box that does not touch the image border.
std::vector<const synthetic::TruthObject*> boxableObjects(const synthetic::TruthFrame& truth,
                                                          int image_cols, int image_rows,
                                                          std::size_t min_pixels);

/// An object to box: the ROI an operator would draw around it (its image bounds) and the 3D
/// points it shows (its pixels with depth).
struct BoxTarget {
  cv::Rect roi;
  std::vector<Eigen::Vector3d> points;
};

/// The boxableObjects of a synthetic frame with at least `min_image_share` of the image.
std::vector<BoxTarget> syntheticBoxTargets(const synthetic::RenderedFrame& rendered,
                                           double min_image_share);

/// The labelled objects of a real OSD frame with at least `min_image_share` of the image in
/// pixels with depth.
std::vector<BoxTarget> realBoxTargets(const LabelledFrame& frame, double min_image_share);

}  // namespace shapesense::eval
