#pragma once
// The detectors run on every frame, as one ordered chain of stages shared by the daemon,
// `shapesense analyze` and the tools, so all of them compute the same thing. No gRPC and no
// threads here: the daemon's pipeline thread calls process() once per frame.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/geometry/frame.h"
#include "shapesense/core/pipeline/frame_results.h"
#include "shapesense/core/planes/plane_accumulator.h"
#include "shapesense/core/planes/plane_ransac.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/tracking/taught_object_tracker.h"
#include "shapesense/core/tracking/thing_tracker.h"

namespace shapesense {

/// One algorithm of core/ adapted to the chain (stages.h has the standard ones).
class DetectorStage {
 public:
  virtual ~DetectorStage() = default;
  /// Stable name used in status, timings and configuration, e.g. "depth_stats".
  virtual std::string name() const = 0;
  /// Runs on one frame; may read results of stages that ran before it.
  virtual void run(const Frame& frame, FrameResults& results) = 0;
};

/// The ordered stages run on every frame, shared by the daemon and `shapesense analyze` so
/// both compute the same thing.
class DetectorChain {
 public:
  void add(std::unique_ptr<DetectorStage> stage) { stages_.push_back(std::move(stage)); }

  /// Runs every stage in order and records each one's wall time in results.timings_ms. A stage
  /// that throws (a frame its algorithm cannot take) is recorded in results.stage_errors and
  /// the chain goes on: one bad frame or one broken stage does not stop the detectors.
  FrameResults process(const Frame& frame) const;

  std::vector<std::string> stageNames() const;

 private:
  std::vector<std::unique_ptr<DetectorStage>> stages_;
};

/// Where the bowl models are when nobody says: the first folder holding bowl_*.json of
/// <binary's dir>/../share/shapesense/models, <configured prefix>/share/shapesense/models, and
/// the source tree's models/ (a build that was never installed).
std::filesystem::path defaultBowlModelsDir();

/// Which plane detector the plane stage runs.
enum class PlaneDetectorKind { kHough, kRansac };

/// Options that select and configure the stages; filled from the daemon's config or the CLI.
struct DetectorConfig {
  /// Method of the segmentation stage; nullopt leaves the stage out.
  std::optional<SegmentationMethod> segmentation = kDefaultSegmentationMethod;
  SegmentationParams segmentation_params;
  /// Plane detector of the plane stage; nullopt leaves the stage out.
  std::optional<PlaneDetectorKind> planes = PlaneDetectorKind::kHough;
  HoughPlaneParams hough_params;
  RansacPlaneParams ransac_params;
  PlaneAccumulatorParams accumulator_params;
  /// Boxes for segments standing on planes; only when both stages above are on.
  bool object_boxes = true;
  ObjectBoxParams object_box_params;
  /// The bowl stage; on by default. makeDetectorChain loads its models and throws when they
  /// do not load, so a daemon started with bowls on and no usable models fails at startup.
  bool bowls = true;
  /// Folder of bowl_*.json models (or one model file); empty = defaultBowlModelsDir().
  std::filesystem::path bowl_models;
  /// Default: the parameters the shipped models were evaluated with. `parallel` is ignored:
  /// the stage always runs single-threaded on the pipeline's detector thread.
  BowlDetectorParams bowl_params;
  /// The 3D check of each detection (rim diameter range and shape). Default: defaults.
  BowlGeometryParams bowl_geometry_params;
  /// How each bowl's 3D box is estimated (always mode 2, see detectBowls). Default: defaults.
  BoxEstimationParams bowl_box_params;
  /// Tracking of object boxes and bowls over frames (the scene model's things); runs when
  /// either stage does. Default on.
  bool track_things = true;
  ThingTrackerParams tracker_params;
  /// The taught-object stage (TaughtObjectStage) runs when this is set: the models to look
  /// for, asked on every frame. Default unset: off (the daemon sets it with
  /// --taught-objects on).
  TaughtModelSource taught_models;
  /// Its parameters; `describe` must be what the models were taught with. Default: defaults.
  TaughtObjectTrackerParams taught_tracker_params;
};

/// "hough" / "ransac" <-> PlaneDetectorKind.
std::optional<PlaneDetectorKind> parsePlaneDetector(std::string_view name);
const char* toString(PlaneDetectorKind kind);

/// The standard chain for `config`. Throws std::runtime_error naming the folder when the bowl
/// stage is on and its models do not load.
DetectorChain makeDetectorChain(const DetectorConfig& config);

}  // namespace shapesense
