#pragma once
// Comparison of a depth image against the one it was made from after a trip through the
// Kinect's raw 11-bit disparity (fakenect dumps, the libfreenect path).

#include <opencv2/core.hpp>

namespace shapesense::testing {

struct RawRoundTripComparison {
  int compared = 0;    ///< pixels valid in both images
  int violations = 0;  ///< pixels off by more than half a raw step (+0.5 mm), or valid in only one
};

/// Compares two CV_16UC1 millimetre images of the same size. A raw step at depth z is
/// kinectRawDepthStep(z); rounding to the nearest raw value moves a depth by at most half of it
/// (2% slack for the step's change within one step, 0.5 mm for millimetre rounding).
RawRoundTripComparison compareThroughRawDisparity(const cv::Mat& original_mm,
                                                  const cv::Mat& back_mm);

}  // namespace shapesense::testing
