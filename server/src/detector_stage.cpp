#include "shapesense/server/detector_stage.h"

#include <array>
#include <chrono>

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
    : kind_(kind), hough_(std::move(hough)), ransac_(std::move(ransac)), accumulator_(accumulator) {}

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

DetectorChain makeDetectorChain(const DetectorConfig& config) {
  DetectorChain chain;
  chain.add(std::make_unique<DepthStatsStage>());
  if (config.segmentation) {
    chain.add(std::make_unique<SegmentationStage>(*config.segmentation, config.segmentation_params));
  }
  if (config.planes) {
    chain.add(std::make_unique<PlaneStage>(*config.planes, config.hough_params, config.ransac_params,
                                           config.accumulator_params));
  }
  if (config.object_boxes && config.segmentation && config.planes) {
    chain.add(std::make_unique<ObjectBoxStage>(config.object_box_params));
  }
  return chain;
}

}  // namespace shapesense
