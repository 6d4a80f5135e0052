// estimateBox with any intrinsics (raw doubles: NaN, infinities, denormals), ROI, mode and a
// small depth image: a result or a failure, never a crash or an unbounded allocation (libFuzzer's
// -rss_limit_mb catches the latter).
#include <fuzzer/FuzzedDataProvider.h>

#include <bit>
#include <cstddef>
#include <cstdint>

#include "shapesense/core/boxes/box_estimation.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  const auto raw_double = [&] {
    return std::bit_cast<double>(input.ConsumeIntegral<std::uint64_t>());
  };
  shapesense::CameraIntrinsics k;
  k.fx = raw_double();
  k.fy = raw_double();
  k.cx = raw_double();
  k.cy = raw_double();
  const int cols = input.ConsumeIntegralInRange(1, 64);
  const int rows = input.ConsumeIntegralInRange(1, 48);
  k.width = cols;
  k.height = rows;
  const cv::Point p1(input.ConsumeIntegralInRange(-2, 66), input.ConsumeIntegralInRange(-2, 50));
  const cv::Point p2(input.ConsumeIntegralInRange(-2, 66), input.ConsumeIntegralInRange(-2, 50));
  const auto mode = static_cast<shapesense::BoxMode>(input.ConsumeIntegralInRange(0, 4));
  cv::Mat depth(rows, cols, CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < rows; ++v) {
    for (int u = 0; u < cols; ++u)
      depth.at<std::uint16_t>(v, u) = input.ConsumeIntegral<std::uint16_t>();
  }
  const auto result = shapesense::estimateBox(depth, k, p1, p2, mode);
  (void)result;
  return 0;
}
