#pragma once
// Detection scoring for the bowl detector: PASCAL VOC average precision (all-point
// interpolated, VOC 2010+) at an IoU threshold, and the log-average-free "miss rate at a
// false-positives-per-frame budget" used in pedestrian detection.

#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/geometry/image_boxes.h"

namespace shapesense {

struct BowlTruthBox {
  cv::Rect box;
  /// Ignored: matching it is neither a true nor a false positive, missing it is no miss
  /// (tiny, mostly hidden or out-of-range bowls: isDifficultBowl).
  bool difficult = false;
};

/// A bowl too small or too sparse in the image to learn or find: its box (the bounds of its
/// pixels) under 20 x 12 px, or less than a quarter of the box covered by its pixels.
bool isTinyOrSparseBowl(const cv::Rect& box, std::size_t pixel_count);

/// Bowls of which the sensor sees less than this fraction of the whole silhouette are difficult.
inline constexpr double kMinVisibleBowlFraction = 0.5;

/// The truth rule of every bowl evaluation (shapesense-train datasets, the tests, the bench):
/// difficult = tiny or sparse (isTinyOrSparseBowl), or visible_fraction below
/// kMinVisibleBowlFraction (its pixels with depth over the area of its whole silhouette, e.g.
/// synthetic::TruthObject::visible_fraction): mostly hidden behind other objects, cut by the
/// image border, or reading no depth (nearer than the sensor's range, in shadow, at grazing
/// angles). As PASCAL VOC's "difficult" objects, such bowls are neither required nor counted as
/// false detections.
bool isDifficultBowl(const cv::Rect& box, std::size_t pixel_count, double visible_fraction);

struct BowlEvalFrame {
  std::vector<BowlDetection> detections;
  std::vector<BowlTruthBox> truth;
};

struct BowlEvalResult {
  double ap = 0.0;                 ///< average precision at the IoU threshold
  double miss_rate_at_fppi = 1.0;  ///< 1 - recall at the lowest score keeping FP/frame <= fppi
  double max_recall = 0.0;         ///< recall with every detection
  int positives = 0;               ///< non-difficult truth boxes
  int frames = 0;
  int true_positives = 0;  ///< at the lowest score (all detections)
  int false_positives = 0;
};

/// Greedy VOC matching per frame in decreasing score: a detection is a true positive when its
/// best-IoU unmatched truth box has IoU >= iou (a difficult one: ignored), else a false positive.
BowlEvalResult evaluateBowlDetections(const std::vector<BowlEvalFrame>& frames, double iou = 0.5,
                                      double fppi = 0.1);

}  // namespace shapesense
