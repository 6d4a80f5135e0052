#include "segmentation/working_image.h"

#include <algorithm>
#include <cstdint>

#include "segmentation/segmentation_kernels.h"

namespace shapesense::segmentation {

WorkingImage makeWorkingImage(const cv::Mat& depth, const CameraIntrinsics& intr,
                              const RegionParams& rp) {
  CV_Assert(depth.type() == CV_16UC1);
  WorkingImage w;
  w.ds = std::clamp(rp.downsample, 1, 2);
  // An image with a single row or column has no 2x2 block to reduce.
  if (depth.rows < 2 || depth.cols < 2) w.ds = 1;
  if (w.ds == 1) {
    w.depth = depth;
    w.intr = intr;
    return w;
  }
  const int rows = depth.rows / 2, cols = depth.cols / 2;
  w.depth.create(rows, cols, CV_16UC1);
  // 3 quantisation steps in mm at range z mm: k * z^2.
  const float k =
      static_cast<float>(3.0 * rp.noise.disparity_step_px / rp.noise.focal_baseline_px_m * 1e-3);
  for (int v = 0; v < rows; ++v) {
    reduceRow(depth.ptr<std::uint16_t>(2 * v), depth.ptr<std::uint16_t>(2 * v + 1), cols, k,
              w.depth.ptr<std::uint16_t>(v));
  }
  w.intr = intr;
  w.intr.fx = intr.fx / 2.0;
  w.intr.fy = intr.fy / 2.0;
  w.intr.cx = (intr.cx - 0.5) / 2.0;
  w.intr.cy = (intr.cy - 0.5) / 2.0;
  w.intr.width = cols;
  w.intr.height = rows;
  return w;
}

cv::Mat inverseDepth(const cv::Mat& depth) {
  cv::Mat z;
  depth.convertTo(z, CV_32F);
  cv::Mat w;
  cv::divide(1000.0, cv::max(z, 1.0f), w);
  w.setTo(0.0f, depth == 0);
  return w;
}

}  // namespace shapesense::segmentation
