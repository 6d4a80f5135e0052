#pragma once
// The last check of a plane detection: a region whose samples a quadric fits markedly better
// than its plane, with a curvature no flat surface shows, lies on a curved surface (the side
// of a tin, a ball, a bowl) and is not reported as a plane.

#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense::labeling {

/// Drops the curved regions of `detection` (their pixels become 0) and renumbers the rest
/// 1, 2, ... in their order. Uses the samples of `grid` under each region.
void dropCurvedRegions(const PlaneSampleGrid& grid, const PlaneLabelingParams& params,
                       PlaneDetection& detection);

}  // namespace shapesense::labeling
