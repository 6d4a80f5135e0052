#include "depth_compare.h"

#include <cstdint>
#include <cstdlib>

#include "shapesense/driver/kinect_raw.h"

namespace shapesense::testing {

RawRoundTripComparison compareThroughRawDisparity(const cv::Mat& original_mm,
                                                  const cv::Mat& back_mm) {
  CV_Assert(original_mm.type() == CV_16UC1 && back_mm.type() == CV_16UC1 &&
            original_mm.size() == back_mm.size());
  RawRoundTripComparison result;
  for (int y = 0; y < original_mm.rows; ++y) {
    const auto* a_row = original_mm.ptr<std::uint16_t>(y);
    const auto* b_row = back_mm.ptr<std::uint16_t>(y);
    for (int x = 0; x < original_mm.cols; ++x) {
      const int a = a_row[x], b = b_row[x];
      if (a == 0 || b == 0) {
        result.violations += (a == 0) != (b == 0);
        continue;
      }
      ++result.compared;
      const double bound = 1000.0 * kinectRawDepthStep(a / 1000.0) / 2.0 * 1.02 + 0.5;
      result.violations += std::abs(a - b) > bound;
    }
  }
  return result;
}

}  // namespace shapesense::testing
