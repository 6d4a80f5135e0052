#pragma once
// Overlap of axis-aligned image boxes, shared by detection (non-maximum suppression) and
// evaluation (matching detections to truth).

#include <opencv2/core.hpp>

namespace shapesense {

/// Intersection over union of two boxes (0 when either is empty).
inline double boxIoU(const cv::Rect& a, const cv::Rect& b) {
  const double intersection = (a & b).area();
  const double union_area = static_cast<double>(a.area()) + b.area() - intersection;
  return union_area > 0 ? intersection / union_area : 0.0;
}

}  // namespace shapesense
