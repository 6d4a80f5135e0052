#pragma once
// A detector stage: one algorithm of core/ adapted to the pipeline. Each stage reads the frame
// and writes its own member of FrameResults.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/geometry/frame.h"
#include "shapesense/core/planes/plane_accumulator.h"
#include "shapesense/core/planes/plane_ransac.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/server/frame_results.h"

namespace shapesense {

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

  /// Runs every stage in order and records each one's wall time in results.timings_ms.
  FrameResults process(const Frame& frame) const;

  std::vector<std::string> stageNames() const;

 private:
  std::vector<std::unique_ptr<DetectorStage>> stages_;
};

/// Computes DepthStatistics: the trivial statistic every frame gets.
class DepthStatsStage : public DetectorStage {
 public:
  std::string name() const override { return "depth_stats"; }
  void run(const Frame& frame, FrameResults& results) override;
};

/// Pure function behind DepthStatsStage.
DepthStatistics computeDepthStatistics(const cv::Mat& depth_mm);

/// Segments the depth image with one method and computes per-segment statistics.
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

/// Which plane detector the plane stage runs.
enum class PlaneDetectorKind { kHough, kRansac };

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

/// The bowls of one frame with their boxes: what BowlStage computes, as a pure function.
/// `planes`: the plane detection of the same frame.
std::vector<DetectedBowl> detectBowls(const Frame& frame, const BowlDetector& detector,
                                      const PlaneDetection& planes,
                                      const BowlGeometryParams& geometry_params = {},
                                      const BoxEstimationParams& box_params = {});

/// Where the bowl models are when nobody says: the first folder holding bowl_*.json of
/// <binary's dir>/../share/shapesense/models, <configured prefix>/share/shapesense/models, and
/// the source tree's models/ (a build that was never installed).
std::filesystem::path defaultBowlModelsDir();

/// Segmentation of one frame with any method: what the stage and on-request queries share.
SegmentationResult segmentFrame(const Frame& frame, SegmentationMethod method,
                                const SegmentationParams& params = {});

/// Options that select and configure the stages; filled from the daemon's config or the CLI.
struct DetectorConfig {
  /// Method of the segmentation stage; nullopt leaves the stage out.
  std::optional<SegmentationMethod> segmentation = SegmentationMethod::kDepthStep;
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
};

/// "hough" / "ransac" <-> PlaneDetectorKind.
std::optional<PlaneDetectorKind> parsePlaneDetector(std::string_view name);
const char* toString(PlaneDetectorKind kind);

/// The standard chain for `config`. Throws std::runtime_error naming the folder when the bowl
/// stage is on and its models do not load.
DetectorChain makeDetectorChain(const DetectorConfig& config);

}  // namespace shapesense
