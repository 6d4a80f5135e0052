#pragma once
// The connected regions of labelPlanes: samples of one plane joined into regions on the sample
// grid (union-find over `parent`, whose roots are the smallest index of their set, so a set's
// root is its first sample in raster order), then numbered and pruned.

#include <cstddef>
#include <span>
#include <vector>

#include "planes/pixel_labeling.h"
#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense::labeling {

/// Joins each labelled sample with its left and upper neighbours of the same plane that are
/// depth-continuous with it (4-connected regions). `parent` starts as every sample its own set.
void connectSamples(const PlaneSampleGrid& grid, const int* lab, const SampleContinuity& continuous,
                    std::span<int> parent);

/// Pieces of one plane separated only by things in front of it (a floor seen between table
/// legs, a wall behind a box) are one surface: SegComp truth and users both see one floor.
/// Pieces separated by surface *behind* the plane (two box tops at the same height, with the
/// table between them) are distinct surfaces. Test: walk the image line between the pieces'
/// centroids; it may cross the plane's own pieces, holes and occluders, but (almost) no sample
/// farther along its ray than the plane. Flattens `parent` (every entry its root) on the way.
void mergeOccludedPieces(const PlaneSampleGrid& grid, const int* lab,
                         const std::vector<PlaneHypothesis>& planes,
                         const PlaneLabelingParams& params, std::span<int> parent);

/// One region per set of `parent` (split) or per plane (not split), numbered in raster order of
/// their first sample: region_of (every sample; -1 for unlabelled ones) and each region's plane,
/// sample count and sample box.
void buildRegions(const PlaneSampleGrid& grid, const int* lab, std::span<int> parent, bool split,
                  std::size_t planes, int* region_of, std::vector<RegionAccumulator>& regions);

/// Pre-filter on sample counts (half the pixel threshold: edges add pixels at full resolution):
/// the samples of smaller regions leave them (region_of = -1). Pixels are labelled with region
/// index + 1 in 16 bits: past 65535 regions, the kept ones are renumbered in order and those still
/// past the range are dropped as well.
void dropSmallRegions(const PlaneSampleGrid& grid, int min_region_pixels, int* region_of,
                      std::vector<RegionAccumulator>& regions);

}  // namespace shapesense::labeling
