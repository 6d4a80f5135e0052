#pragma once
// The edge-strength images the watershed methods flood: CV_8UC1 at working resolution, a small
// count per pixel of the window neighbours that lie across an edge, kNoDepth where there is no
// depth.

#include <opencv2/core.hpp>

#include "segmentation/working_image.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// Depth-step edge strength: per pixel, the number of valid neighbours in the window whose
/// depth differs by more than the ring's threshold.
cv::Mat depthStepEdges(const WorkingImage& w, const DepthStepEdgeParams& p,
                       const KinectNoiseModel& noise);

/// Roof-edge strength: the number of valid-depth neighbours whose normal differs by more than
/// the angle. With `invalid_is_edge` a neighbour with depth but no normal counts as differing
/// and a centre without normal gets the full count (see the .cpp).
cv::Mat normalEdges(const WorkingImage& w, const NormalAngleEdgeParams& p,
                    bool invalid_is_edge = true);

/// kFused: depth-step edges plus normal_weight times the roof edges, at most 254.
cv::Mat fusedEdges(const WorkingImage& w, const FusedParams& p);

/// Plane-prediction edge strength (see PlanePredictionParams). With `short_edges`, also returns
/// the dense-window count alone (for the fallback markers).
cv::Mat planePredictionEdges(const WorkingImage& w, const PlanePredictionParams& p,
                             const KinectNoiseModel& noise, cv::Mat* short_edges = nullptr);

/// The edge image of a watershed method; empty for kTiledRansac.
cv::Mat edgeStrength(const WorkingImage& w, SegmentationMethod method,
                     const SegmentationParams& params);

}  // namespace shapesense::segmentation
