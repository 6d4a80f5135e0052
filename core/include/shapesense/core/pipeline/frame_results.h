#pragma once
// What the detector pipeline computed from one frame. Each detector fills its own member;
// a member a detector did not produce stays empty.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/boxes/object_boxes.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/segmentation/segment_statistics.h"
#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/core/tracking/thing_tracker.h"

namespace shapesense {

/// The trivial per-frame statistic computed for every frame.
struct DepthStatistics {
  double valid_fraction = 0.0;
  double min_m = 0.0;
  double median_m = 0.0;
  double max_m = 0.0;
};

/// A depth segmentation of the frame.
struct SegmentationResult {
  SegmentationMethod method = kDefaultSegmentationMethod;
  cv::Mat labels;  ///< CV_16UC1 region ids, 0 = unassigned
  std::vector<SegmentStatistics> segments;
};

/// Planes of the frame and the planes accumulated over the frames up to it.
struct PlaneResult {
  std::string detector;                    ///< "hough" or "ransac"
  PlaneDetection frame;                    ///< this frame's planes and their label image
  std::vector<DetectedPlane> accumulated;  ///< stable planes over time (ids are track ids)
};

/// A bowl the bowl stage found, with the 3D box behind its image box.
struct DetectedBowl {
  BowlDetection detection;  ///< box clipped to the image
  /// From estimateBox over detection.box; nullopt when the box holds no valid depth reading.
  std::optional<BoxEstimate> box;
};

struct FrameResults {
  std::optional<DepthStatistics> depth_stats;
  std::optional<SegmentationResult> segmentation;
  std::optional<PlaneResult> planes;
  /// Boxes of segments standing on a plane (needs both the segmentation and plane stages).
  std::vector<ObjectBox> object_boxes;
  /// Bowls of the bowl stage, highest score first; nullopt when the stage is off (an empty
  /// list means it ran and found none).
  std::optional<std::vector<DetectedBowl>> bowls;
  /// The object boxes and bowls tracked over the frames up to this one (confirmed tracks only,
  /// ordered by id); nullopt when the tracking stage is off.
  std::optional<std::vector<TrackedThing>> things;
  /// The taught objects found in this frame (TaughtObjectStage), in the models' order;
  /// nullopt when the stage is off.
  std::optional<std::vector<ObjectDetection>> taught_objects;
  /// The stages that failed on this frame (threw), by name, with the reason. A failed stage's
  /// member may be missing or partial; the stages after it still ran.
  std::map<std::string, std::string> stage_errors;
  /// Wall time of each stage on this frame, milliseconds, by stage name.
  std::map<std::string, double> timings_ms;
};

}  // namespace shapesense
