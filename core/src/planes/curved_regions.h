#pragma once
// The last check of a plane region: a region whose samples a quadric fits markedly better
// than its plane, with a curvature no flat surface shows, lies on a curved surface (the side
// of a tin, a ball, a bowl) and is not reported as a plane. So do two adjacent regions that
// each bend and that one such quadric fits together as well as their two planes do: facets
// of one bin or column, each too narrow to tell on its own.

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense::labeling {

/// Which regions are curved. `region_labels`: CV_16UC1 full-resolution labels, region k as
/// k + 1; `root`: the region each region was merged into (itself when none); `candidate`:
/// whether region k is a root that would be reported, with `normals[k]` its fitted plane
/// normal. A region's samples are those of `grid` whose pixel belongs to it or to a region
/// merged into it. Empty when the check is off.
std::vector<bool> curvedRegions(const PlaneSampleGrid& grid, const cv::Mat& region_labels,
                                const std::vector<int>& root, const std::vector<bool>& candidate,
                                const std::vector<Eigen::Vector3d>& normals,
                                const PlaneLabelingParams& params);

}  // namespace shapesense::labeling
