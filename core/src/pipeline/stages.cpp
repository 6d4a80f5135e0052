#include "shapesense/core/pipeline/stages.h"

#include <algorithm>
#include <stdexcept>

namespace shapesense {

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
                                const SegmentationParams& params, const PlaneDetection* planes) {
  SegmentationResult result;
  result.method = method;
  result.labels = planes ? segmentWithPlanes(frame.depth, frame.intrinsics, method, *planes, params)
                         : segmentDepth(frame.depth, frame.intrinsics, method, params);
  result.segments = computeSegmentStatistics(result.labels, frame.depth, frame.intrinsics);
  return result;
}

void SegmentationStage::run(const Frame& frame, FrameResults& results) {
  results.segmentation =
      segmentFrame(frame, method_, params_, results.planes ? &results.planes->frame : nullptr);
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

std::vector<ThingObservation> thingObservations(const FrameResults& results) {
  std::vector<ThingObservation> observations;
  std::vector<cv::Rect> bowl_boxes;
  if (results.bowls) {
    for (const auto& bowl : *results.bowls) {
      if (!bowl.box) continue;
      observations.push_back(
          {ThingKind::kBowl, bowl.box->corners, bowl.detection.box, bowl.detection.score});
      bowl_boxes.push_back(bowl.detection.box);
    }
  }
  const auto sameAsABowl = [&bowl_boxes](const cv::Rect& box) {
    return std::any_of(bowl_boxes.begin(), bowl_boxes.end(), [&box](const cv::Rect& bowl) {
      const int smaller = std::min(box.area(), bowl.area());
      return smaller > 0 && 2 * (box & bowl).area() > smaller;
    });
  };
  for (const auto& object : results.object_boxes) {
    if (sameAsABowl(object.roi)) continue;
    observations.push_back({ThingKind::kObject, object.box.corners, object.roi, 0.0});
  }
  return observations;
}

void ThingTrackingStage::run(const Frame&, FrameResults& results) {
  results.things = tracker_.update(thingObservations(results));
}

void TaughtObjectStage::run(const Frame& frame, FrameResults& results) {
  results.taught_objects = tracker_.update(frame.depth, frame.intrinsics, models_(),
                                           results.planes ? &results.planes->frame : nullptr);
}
}  // namespace shapesense
