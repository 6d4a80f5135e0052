#pragma once
// Merging of regions that lie on one plane (RegionParams::merge_coplanar).

#include <opencv2/core.hpp>

#include "segmentation/working_image.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// Greedy merge of coplanar regions of `labels` (CV_32SC1, ids up to max_label, relabelled in
/// place): a plane w = a u + b v + c in inverse depth is fitted to each region's core (pixels
/// with edge <= marker_max_edge), and the pair whose union fits best within
/// coplanar_rms_steps is merged first, until no pair fits. Does nothing unless
/// rp.merge_coplanar.
void mergeCoplanarRegions(cv::Mat& labels, int max_label, const cv::Mat& edges,
                          const WorkingImage& w, const RegionParams& rp);

}  // namespace shapesense::segmentation
