#pragma once
// Region growing over an edge-strength image, shared by every method: markers from low-edge
// areas, an immersion flood from them, and the full-resolution labels from the flooded
// working-resolution ones.

#include <opencv2/core.hpp>

#include "segmentation/working_image.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// Markers: 4-connected components of pixels with edge <= max_edge, components below min_px
/// dropped. With `fallback` (a second relief, e.g. plane prediction's dense window alone), its
/// low-edge components that contain no marker pixel become markers too. CV_32SC1,
/// 0 = unmarked. Returns the number of the largest label used.
int markersFromEdges(const cv::Mat& edges, int max_edge, int min_px, cv::Mat& markers,
                     const cv::Mat& fallback = {});

/// Floods `markers` (CV_32SC1, modified: every pixel ends with a label > 0 when at least one
/// marker exists) over the relief `edges` by immersion (see the .cpp).
void flood(const cv::Mat& edges, cv::Mat& markers);

/// The full-resolution regions (CV_16UC1, 1..N compact, 0 = unassigned) from flooded
/// working-resolution markers (ids up to max_label): coplanar regions merged, labels upsampled
/// to `depth`, small regions dropped.
cv::Mat finishRegions(cv::Mat& markers, int max_label, const cv::Mat& edges, const WorkingImage& w,
                      const cv::Mat& depth, const RegionParams& rp);

}  // namespace shapesense::segmentation
