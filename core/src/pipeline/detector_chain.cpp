#include "shapesense/core/pipeline/detector_chain.h"

#include "shapesense/core/pipeline/stages.h"

#include <array>
#include <chrono>
#include <stdexcept>

namespace shapesense {

FrameResults DetectorChain::process(const Frame& frame) const {
  FrameResults results;
  for (const auto& stage : stages_) {
    const auto start = std::chrono::steady_clock::now();
    try {
      stage->run(frame, results);
    } catch (const std::exception& e) {
      results.stage_errors[stage->name()] = e.what();
    }
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

std::optional<PlaneDetectorKind> parsePlaneDetector(std::string_view name) {
  if (name == "hough") return PlaneDetectorKind::kHough;
  if (name == "ransac") return PlaneDetectorKind::kRansac;
  return std::nullopt;
}

const char* toString(PlaneDetectorKind kind) {
  return kind == PlaneDetectorKind::kHough ? "hough" : "ransac";
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
  if (config.planes) {
    chain.add(std::make_unique<PlaneStage>(*config.planes, config.hough_params,
                                           config.ransac_params, config.accumulator_params));
  }
  // After the planes: the default segmentation builds on them.
  if (config.segmentation) {
    chain.add(
        std::make_unique<SegmentationStage>(*config.segmentation, config.segmentation_params));
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
  const bool has_object_boxes = config.object_boxes && config.segmentation && config.planes;
  if (config.track_things && (has_object_boxes || config.bowls)) {
    chain.add(std::make_unique<ThingTrackingStage>(config.tracker_params));
  }
  if (config.taught_models) {
    chain.add(
        std::make_unique<TaughtObjectStage>(config.taught_models, config.taught_tracker_params));
  }
  return chain;
}

}  // namespace shapesense
