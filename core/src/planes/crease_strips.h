#pragma once
// Two steps of labelPlanes, after every pixel took the closest plane within its tolerance: the
// strips planes took across creases are given back, and so are the smaller faces of regions
// that hold two.
//
// Where a surface meets another at a crease (a leg's two faces, a box top and its front), the
// pixels of the other surface stay within the plane's tolerance for a strip along the crease,
// as wide as the tolerance: several pixels at 1.5 m, a fifth of a leg face 5 cm wide. Where the
// other surface was found as a plane and is among a pixel's candidates, the closest-plane rule
// hands the strip to it; where it was not (narrow, or unreliable normals), the strip stays with
// the plane, which then holds a piece of a neighbour (a spurious plane) and leaves the
// neighbour short.
//
// A pixel of a strip tells itself apart by its surroundings: the residuals to the plane around
// it lean to one side (their mean lies off the plane) and part of them lie outside the noise,
// where the other surface bends away. Around a pixel of the plane itself they average out,
// and a hole or an occluding edge (no reading, or readings far off) adds none of them. So the
// step peels, from a region's boundary inwards, the pixels whose window (only readings within
// reach of the plane) has both a mean residual beyond `crease_mean_sigmas` of the plane's noise
// and `crease_min_outside_share` of its readings beyond `crease_outside_sigmas` on that side.
// A strip is peeled pass by pass from its outer edge; the crease itself stops it. Its outer
// edge is looked for only near samples that border another region, or none, within reach
// (peelCreaseStrips).
//
// Far off, the tolerance can take both faces whole: a box's side and its top, or a book and the
// table under it, both lie within a few centimetres of one plane between them, which fits
// neither, and no strip shows at a boundary. giveBackSmallerFaces, after the curvature check (a
// curved surface cut down to one of its "faces" would pass it), fits two planes to each region
// whose plane leaves more than the sensor's quantisation (PlaneLabelingParams::minor_face_*);
// where they fit it much better and meet at a crease or lie further apart than the sensor
// resolves, the region gives back the pixels of the smaller face.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "planes/pixel_labeling.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/plane_labeling.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense::labeling {

/// Peels crease strips off the regions of `labels` (CV_16UC1, region index + 1, as labelPixels
/// leaves it) and takes their pixels out of the counts, bounds, moments and colour of the
/// regions they were merged into (`root`: per region, the region holding its sums; itself when
/// not merged). Each region is tested against its root's plane. `noise_steps`: per plane
/// hypothesis, the RMS residual of its samples in sensor depth steps (planeNoiseSteps; negative
/// when too few to tell), the sigma of its regions' readings. `bgr`
/// as given to labelPixels (empty: no colour). `grid` and `region_of` (the region of each
/// sample, -1 none) as labelPixels had them: strips are looked for only near samples whose
/// neighbourhood holds another region or none. `peeled_pixels` becomes a CV_8UC1 image of the
/// labels' size, 1 at the pixels peeled, or empty when none was. Returns per region whether it
/// lost pixels (only roots do).
std::vector<std::uint8_t> peelCreaseStrips(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                           const cv::Mat& bgr, const PlaneSampleGrid& grid,
                                           const int* region_of, const PlaneLabelingParams& params,
                                           const std::vector<double>& noise_steps,
                                           const std::vector<int>& root,
                                           std::vector<RegionAccumulator>& regions, cv::Mat& labels,
                                           cv::Mat& peeled_pixels);

/// Takes the smaller face off each region on two faces (see above), but for the regions marked
/// curved, with its pixels out of the sums of the region they were merged into. `root`,
/// `regions` and `labels` as for peelCreaseStrips; the pixels given back are set to 1 in
/// `peeled_pixels` (created when empty). Returns per region whether it lost pixels.
std::vector<std::uint8_t> giveBackSmallerFaces(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                               const cv::Mat& bgr,
                                               const PlaneLabelingParams& params,
                                               const std::vector<int>& root,
                                               std::vector<RegionAccumulator>& regions,
                                               cv::Mat& labels, cv::Mat& peeled_pixels);

}  // namespace shapesense::labeling
