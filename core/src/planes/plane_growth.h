#pragma once
// The last step of labelPlanes: the parts of a plane's surface that no sample reached.
//
// Pixels take a plane only near a sample of its region, and the samples grow only where their
// normals agree with the plane. On a noisy face, or a narrow one seen obliquely, whole patches
// of samples carry normals too far off, and the face comes out found in part: its pixels there
// lie on the plane, within the plane's tolerance, but are left without a label. This step
// hands such pixels to the plane next to them, ring by ring from its border.

#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/depth_step.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense::labeling {

/// Pixels with depth and no plane in `detection.labels`, 4-connected to a plane's pixels, take
/// that plane where they lie within its tolerance, max(tolerance_floor_m, tolerance_at_1m[id] z^2)
/// (metres; z in metres), and without a depth step (`continuity`) to the pixel they are reached
/// from. Growth goes ring by ring from every plane at once; the first plane to reach a pixel
/// takes it. Pixels set in `blocked` (CV_8UC1, or empty) are never taken. Each plane's inliers
/// and box take in its new pixels. The planes' ids are 1..N in order (detection.planes[id - 1]
/// is plane id), as labelPlanes numbers them. Returns the number of pixels taken.
std::size_t growPlanesIntoUnlabelled(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                     const std::vector<float>& tolerance_at_1m,
                                     float tolerance_floor_m, const DepthStepRule& continuity,
                                     const cv::Mat& blocked, PlaneDetection& detection);

}  // namespace shapesense::labeling
