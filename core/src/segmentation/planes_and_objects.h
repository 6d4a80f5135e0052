#pragma once
// kPlanesAndObjects: the plane detector's planes as regions, the rest split into objects.

#include "shapesense/core/planes/planes.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// Every plane of `planes` (a detection of this depth image) is a region; the pixels no plane
/// covers take the plane_prediction regions they lie in, each connected piece of one a region
/// of its own; pixels left (region borders, pieces below the size limit) join a
/// depth-continuous neighbouring region.
cv::Mat segmentPlanesAndObjects(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                const PlaneDetection& planes, const SegmentationParams& params);

}  // namespace shapesense::segmentation
