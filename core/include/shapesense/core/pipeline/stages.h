#pragma once
// The stages of the standard chain: each adapts one capability of core/ to a frame and writes
// its own member of FrameResults. Their pure functions (computeDepthStatistics, segmentFrame,
// detectBowls) are what on-request queries share with the stages.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/planes/plane_accumulator.h"
#include "shapesense/core/planes/plane_ransac.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/tracking/taught_object_tracker.h"
#include "shapesense/core/tracking/thing_tracker.h"

namespace shapesense {

/// Computes DepthStatistics: the trivial statistic every frame gets.
class DepthStatsStage : public DetectorStage {
 public:
  std::string name() const override { return "depth_stats"; }
  void run(const Frame& frame, FrameResults& results) override;
};

/// Pure function behind DepthStatsStage.
DepthStatistics computeDepthStatistics(const cv::Mat& depth_mm);

/// Segments the depth image with one method and computes per-segment statistics. Runs after
/// the plane stage, whose planes kPlanesAndObjects takes as its planar regions.
class SegmentationStage : public DetectorStage {
 public:
  SegmentationStage(SegmentationMethod method, SegmentationParams params)
      : method_(method), params_(params) {}
  std::string name() const override { return "segmentation"; }
  void run(const Frame& frame, FrameResults& results) override;

 private:
  SegmentationMethod method_;
  SegmentationParams params_;
};

/// Detects the frame's planes and adds them to the accumulated planes. Holds the accumulator,
/// so one instance must see the frames in order (the pipeline's detector thread does).
class PlaneStage : public DetectorStage {
 public:
  PlaneStage(PlaneDetectorKind kind, HoughPlaneParams hough, RansacPlaneParams ransac,
             PlaneAccumulatorParams accumulator);
  std::string name() const override { return "planes"; }
  void run(const Frame& frame, FrameResults& results) override;

 private:
  PlaneDetectorKind kind_;
  HoughPlaneDetector hough_;
  RansacPlaneParams ransac_;
  PlaneAccumulator accumulator_;
};

/// Turns every segment that stands on a plane into a 3D box (runs after segmentation and planes).
class ObjectBoxStage : public DetectorStage {
 public:
  explicit ObjectBoxStage(ObjectBoxParams params) : params_(params) {}
  std::string name() const override { return "object_boxes"; }
  void run(const Frame& frame, FrameResults& results) override;

 private:
  ObjectBoxParams params_;
};

/// Finds bowls with the trained depth-only detector, keeps those whose depth is bowl-shaped on
/// a support plane (keepBowlShaped) and gives each the 3D box behind its image box. The planes
/// are the plane stage's when it ran before this one on the frame; without a plane stage the
/// bowl stage detects them itself (Hough, default parameters). The detector runs
/// single-threaded (the pipeline owns the threads).
class BowlStage : public DetectorStage {
 public:
  BowlStage(std::unique_ptr<const BowlDetector> detector, BowlGeometryParams geometry_params,
            BoxEstimationParams box_params)
      : detector_(std::move(detector)),
        geometry_params_(geometry_params),
        box_params_(box_params) {}
  std::string name() const override { return "bowls"; }
  void run(const Frame& frame, FrameResults& results) override;

 private:
  std::unique_ptr<const BowlDetector> detector_;
  BowlGeometryParams geometry_params_;
  BoxEstimationParams box_params_;
  std::optional<HoughPlaneDetector> own_planes_;  ///< made on the first frame without a plane stage
};

/// Tracks the frame's object boxes and bowls over time (ThingTracker); runs after both stages.
/// Holds the tracks, so one instance must see the frames in order.
class ThingTrackingStage : public DetectorStage {
 public:
  explicit ThingTrackingStage(ThingTrackerParams params) : tracker_(params) {}
  std::string name() const override { return "tracking"; }
  void run(const Frame& frame, FrameResults& results) override;

 private:
  ThingTracker tracker_;
};

/// Finds the taught objects on every frame and follows them from frame to frame
/// (TaughtObjectTracker). The models are asked for on every frame, so an object taught while
/// the pipeline runs is looked for from the next frame. Needs only the depth. Holds the
/// objects' last poses, so one instance must see the frames in order.
class TaughtObjectStage : public DetectorStage {
 public:
  /// `params.describe`: the parameters the models were taught with.
  TaughtObjectStage(TaughtModelSource models, TaughtObjectTrackerParams params)
      : models_(std::move(models)), tracker_(params) {}
  std::string name() const override { return "taught_objects"; }
  void run(const Frame& frame, FrameResults& results) override;

 private:
  TaughtModelSource models_;
  TaughtObjectTracker tracker_;
};

/// The things of one frame's results as tracker observations: every bowl with a 3D box, and
/// every object box that is not the same thing as a bowl (image boxes overlapping by more than
/// half of the smaller one), as a bowl is the more specific description.
std::vector<ThingObservation> thingObservations(const FrameResults& results);

/// The bowls of one frame with their boxes: what BowlStage computes, as a pure function.
/// `planes`: the plane detection of the same frame.
std::vector<DetectedBowl> detectBowls(const Frame& frame, const BowlDetector& detector,
                                      const PlaneDetection& planes,
                                      const BowlGeometryParams& geometry_params = {},
                                      const BoxEstimationParams& box_params = {});

/// Segmentation of one frame with any method: what the stage and on-request queries share.
/// `planes`: the frame's plane detection when one was made (kPlanesAndObjects uses it instead
/// of detecting its own).
SegmentationResult segmentFrame(const Frame& frame, SegmentationMethod method,
                                const SegmentationParams& params = {},
                                const PlaneDetection* planes = nullptr);

}  // namespace shapesense
