#pragma once
// One captured RGB-D frame: the unit that flows driver -> cache -> detectors -> gRPC.

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

/// Nanoseconds since the Unix epoch of the sensor's capture clock (or the recording's stamps).
using TimestampNs = std::int64_t;

struct Frame {
  cv::Mat depth;                 ///< CV_16UC1, millimetres, 0 = no reading. Always present.
  cv::Mat rgb;                   ///< CV_8UC3 in BGR order (OpenCV), or empty when absent.
  CameraIntrinsics intrinsics;   ///< of the depth image (RGB is assumed registered to it)
  TimestampNs timestamp_ns = 0;  ///< capture time of the depth image
  std::uint64_t sequence = 0;    ///< 0, 1, 2, ... per source, in delivery order
};

}  // namespace shapesense
