#include "shapesense/server/detector_stage.h"

#include <array>
#include <chrono>
#include <stdexcept>

namespace shapesense {

FrameResults DetectorChain::process(const Frame& frame) const {
  FrameResults results;
  for (const auto& stage : stages_) {
    const auto start = std::chrono::steady_clock::now();
    stage->run(frame, results);
    const std::chrono::duration<double, std::milli> took = std::chrono::steady_clock::now() - start;
    results.timings_ms[stage->name()] = took.count();
  }
  return results;
}

std::vector<std::string> DetectorChain::stageNames() const {
  std::vector<std::string> names;
  for (const auto& stage : stages_) names.push_back(stage->name());
  return names;
}

DepthStatistics computeDepthStatistics(const cv::Mat& depth_mm) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  // A histogram over millimetres gives the exact median in one pass without sorting.
  std::vector<std::uint32_t> histogram(65536, 0);
  std::size_t valid = 0;
  for (int v = 0; v < depth_mm.rows; ++v) {
    const auto* row = depth_mm.ptr<std::uint16_t>(v);
    for (int u = 0; u < depth_mm.cols; ++u) ++histogram[row[u]];
  }
  valid = depth_mm.total() - histogram[0];
  DepthStatistics stats;
  if (valid == 0) return stats;
  stats.valid_fraction = static_cast<double>(valid) / static_cast<double>(depth_mm.total());
  int min_mm = 1;
  while (histogram[min_mm] == 0) ++min_mm;
  int max_mm = 65535;
  while (histogram[max_mm] == 0) --max_mm;
  std::size_t seen = 0;
  int median_mm = min_mm;
  for (int mm = min_mm; mm <= max_mm; ++mm) {
    seen += histogram[mm];
    if (seen * 2 >= valid) {
      median_mm = mm;
      break;
    }
  }
  stats.min_m = min_mm * 1e-3;
  stats.max_m = max_mm * 1e-3;
  stats.median_m = median_mm * 1e-3;
  return stats;
}

void DepthStatsStage::run(const Frame& frame, FrameResults& results) {
  results.depth_stats = computeDepthStatistics(frame.depth);
}

SegmentationResult segmentFrame(const Frame& frame, SegmentationMethod method,
                                const SegmentationParams& params) {
  SegmentationResult result;
  result.method = method;
  result.labels = segmentDepth(frame.depth, frame.intrinsics, method, params);
  result.segments = computeSegmentStatistics(result.labels, frame.depth, frame.intrinsics);
  return result;
}

void SegmentationStage::run(const Frame& frame, FrameResults& results) {
  results.segmentation = segmentFrame(frame, method_, params_);
}

std::optional<PlaneDetectorKind> parsePlaneDetector(std::string_view name) {
  if (name == "hough") return PlaneDetectorKind::kHough;
  if (name == "ransac") return PlaneDetectorKind::kRansac;
  return std::nullopt;
}

const char* toString(PlaneDetectorKind kind) {
  return kind == PlaneDetectorKind::kHough ? "hough" : "ransac";
}

PlaneStage::PlaneStage(PlaneDetectorKind kind, HoughPlaneParams hough, RansacPlaneParams ransac,
                       PlaneAccumulatorParams accumulator)
    : kind_(kind),
      hough_(std::move(hough)),
      ransac_(std::move(ransac)),
      accumulator_(accumulator) {}

void PlaneStage::run(const Frame& frame, FrameResults& results) {
  PlaneResult result;
  result.detector = toString(kind_);
  result.frame = kind_ == PlaneDetectorKind::kHough
                     ? hough_.detect(frame.depth, frame.intrinsics, frame.rgb)
                     : detectPlanesRansac(frame.depth, frame.intrinsics, frame.rgb, ransac_);
  // No pose reaches the pipeline yet: the accumulator resets itself when the view changes.
  accumulator_.update(result.frame);
  result.accumulated = accumulator_.planes();
  results.planes = std::move(result);
}

void ObjectBoxStage::run(const Frame& frame, FrameResults& results) {
  if (!results.segmentation || !results.planes) return;
  results.object_boxes =
      boxesOfObjectsOnPlanes(frame.depth, frame.intrinsics, results.segmentation->labels,
                             results.segmentation->segments, results.planes->frame, params_);
}

std::vector<DetectedBowl> detectBowls(const Frame& frame, const BowlDetector& detector,
                                      const PlaneDetection& planes,
                                      const BowlGeometryParams& geometry_params,
                                      const BoxEstimationParams& box_params) {
  std::vector<DetectedBowl> bowls;
  const cv::Rect image(0, 0, frame.depth.cols, frame.depth.rows);
  auto detections =
      keepBowlShaped(detector.detect(frame.depth, frame.intrinsics), frame.depth, frame.intrinsics,
                     planes, geometry_params, detector.operatingPoint().unverified_score_threshold);
  for (auto& detection : detections) {
    DetectedBowl bowl{.detection = std::move(detection), .box = std::nullopt};
    // Pyramid rounding can put a box's edge a pixel past the image; estimateBox rejects that.
    bowl.detection.box &= image;
    const cv::Rect& roi = bowl.detection.box;
    if (!roi.empty()) {
      // The detector was trained on the bounds of a bowl's whole silhouette, so its box
      // contains the bowl's entire projection, rim and far side included: that is mode 2's
      // reading of a ROI. Modes 1 and 3 take the ROI as the front face alone and would widen
      // the back of the box beyond the silhouette by the bowl's depth.
      auto estimate =
          estimateBox(frame.depth, frame.intrinsics, roi.tl(), roi.br() - cv::Point(1, 1),
                      BoxMode::kAxisAlignedContained, box_params);
      if (auto* box = std::get_if<BoxEstimate>(&estimate)) bowl.box = std::move(*box);
    }
    bowls.push_back(std::move(bowl));
  }
  return bowls;
}

void BowlStage::run(const Frame& frame, FrameResults& results) {
  if (results.planes) {
    results.bowls =
        detectBowls(frame, *detector_, results.planes->frame, geometry_params_, box_params_);
    return;
  }
  if (!own_planes_) own_planes_.emplace();
  const PlaneDetection planes = own_planes_->detect(frame.depth, frame.intrinsics);
  results.bowls = detectBowls(frame, *detector_, planes, geometry_params_, box_params_);
  // These planes are the stage's own, which no client sees: no support id to refer to.
  for (auto& bowl : *results.bowls)
    if (bowl.detection.geometry) bowl.detection.geometry->support_plane_id = 0;
}

namespace {

bool holdsBowlModels(const std::filesystem::path& dir) {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    if (name.starts_with("bowl_") && name.ends_with(".json")) return true;
  }
  return false;
}

}  // namespace

std::filesystem::path defaultBowlModelsDir() {
  // Beside the running binary first (<bin>/../share/...), so an install moved to another
  // prefix (cmake --install --prefix, a package) still finds its own models; then the prefix
  // configured at build time; then the source tree of a build that was never installed.
  std::error_code error;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto beside = exe.parent_path().parent_path() / "share" / "shapesense" / "models";
    if (holdsBowlModels(beside)) return beside;
  }
  const std::filesystem::path installed = SHAPESENSE_INSTALLED_MODELS_DIR;
  if (holdsBowlModels(installed)) return installed;
  return SHAPESENSE_SOURCE_MODELS_DIR;
}

DetectorChain makeDetectorChain(const DetectorConfig& config) {
  DetectorChain chain;
  chain.add(std::make_unique<DepthStatsStage>());
  if (config.segmentation) {
    chain.add(
        std::make_unique<SegmentationStage>(*config.segmentation, config.segmentation_params));
  }
  if (config.planes) {
    chain.add(std::make_unique<PlaneStage>(*config.planes, config.hough_params,
                                           config.ransac_params, config.accumulator_params));
  }
  if (config.object_boxes && config.segmentation && config.planes) {
    chain.add(std::make_unique<ObjectBoxStage>(config.object_box_params));
  }
  if (config.bowls) {
    const auto models = config.bowl_models.empty() ? defaultBowlModelsDir() : config.bowl_models;
    BowlDetectorParams params = config.bowl_params;
    params.parallel = false;  // one detector thread per pipeline; OpenCV's pool is not ours to fill
    try {
      chain.add(std::make_unique<BowlStage>(
          std::make_unique<const BowlDetector>(BowlDetector::load(models, params)),
          config.bowl_geometry_params, config.bowl_box_params));
    } catch (const std::exception& e) {
      throw std::runtime_error("the bowl stage is on but its models in '" + models.string() +
                               "' do not load (" + e.what() +
                               "); point --models at a folder of bowl_*.json or use --bowls off");
    }
  }
  return chain;
}

}  // namespace shapesense
