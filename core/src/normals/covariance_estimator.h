#pragma once
// The covariance mode: the normal of a pixel is the smallest eigenvector of the covariance of
// the 3D points in a square window centred on it, from integral images of the first and second
// moments. Internal to core/src/normals/.

#include <opencv2/core.hpp>

#include "normals/normal_workspace.h"
#include "shapesense/core/normals/normals.h"

namespace shapesense::detail {

/// Writes the unit normal of every pixel with a window into `normals` (CV_32FC3, already NaN
/// everywhere). Needs the step marks of markDepthSteps(); builds the points and the distances.
void estimateCovarianceNormals(const NormalParams& params, NormalWorkspace& work, cv::Mat& normals);

}  // namespace shapesense::detail
