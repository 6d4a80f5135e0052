#pragma once
// kTiledRansac: a plane segmenter (see TiledRansacParams).

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// Regions of a CV_16UC1 mm depth image: a RANSAC plane per tile in inverse depth, neighbouring
/// tiles whose planes explain each other merged, the tile planes grown pixel by pixel across
/// tile borders, and the non-planar leftovers grouped by depth steps. Output as segmentDepth.
cv::Mat segmentTiledRansac(const cv::Mat& depth, const CameraIntrinsics& intr,
                           const TiledRansacParams& p);

}  // namespace shapesense::segmentation
