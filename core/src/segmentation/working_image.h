#pragma once
// The working-resolution depth image every segmentation method starts from.

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// Inverse-depth size (1/m) of one sensor quantisation step: constant over range for a
/// disparity sensor (depthStep(z) / z^2).
inline double inverseDepthStep(const KinectNoiseModel& noise) {
  return noise.disparity_step_px / noise.focal_baseline_px_m;
}

/// The depth image at working resolution and the camera that sees it.
struct WorkingImage {
  cv::Mat depth;  ///< CV_16UC1 mm at working resolution
  CameraIntrinsics intr;
  int ds = 1;  ///< downsampling factor from the full image: 1 or 2
};

/// Reduces the depth image by RegionParams::downsample (1 or 2). A 2x2 block keeps the mean of
/// its valid pixels that are within 3 quantisation steps of the nearest one, so that blocks on
/// a depth step take the foreground instead of a mixed depth that belongs to neither surface.
WorkingImage makeWorkingImage(const cv::Mat& depth, const CameraIntrinsics& intr,
                              const RegionParams& rp);

/// Inverse depth (1/m, 0 where invalid), CV_32FC1.
cv::Mat inverseDepth(const cv::Mat& depth);

}  // namespace shapesense::segmentation
