#pragma once
// The gradient modes (3D gradient and depth change): normals from the means of four windows
// around each pixel, read from one packed integral image. Internal to core/src/normals/.

#include <opencv2/core.hpp>

#include "normals/gradient_windows.h"
#include "normals/normal_workspace.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/normals/normals.h"

namespace shapesense::detail {

/// Writes the unit normal (NaN where none) of every pixel into `normals` (CV_32FC3). Needs the
/// step marks of markDepthSteps(); builds the step distances.
void estimateGradientNormals(GradientMode mode, const NormalParams& params,
                             const CameraIntrinsics& intrinsics, NormalWorkspace& work,
                             cv::Mat& normals);

}  // namespace shapesense::detail
