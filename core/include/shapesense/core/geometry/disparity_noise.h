#pragma once
// How noisy a frame's depth is, measured from the frame itself. A sensor's disparity noise
// varies from unit to unit and with the light; rules that tell a depth step from noise by a
// fixed model take the noise of a noisy sensor at range for steps.

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

/// The standard deviation (px) of the disparity noise of `depth_mm` (CV_16UC1, millimetres; a
/// full frame or a subsampled one). On a plane, disparity is an affine function of the pixel,
/// so the second difference of three neighbouring readings along a row is noise alone, of
/// variance 6 sigma^2: sigma is taken from the mean absolute second difference over the rows'
/// valid triples, leaving out those of 1.5 px or more (a depth edge, not noise). It includes
/// the sensor's quantisation. 0 with fewer than 100 such triples.
double disparityNoisePx(const cv::Mat& depth_mm, const KinectNoiseModel& sensor = {});

}  // namespace shapesense
