#include "shapesense/core/geometry/camera.h"

#include <limits>

namespace shapesense {

cv::Mat depthToPoints(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  cv::Mat points(depth_mm.size(), CV_32FC3);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inv_fx = static_cast<float>(1.0 / intrinsics.fx);
  const float inv_fy = static_cast<float>(1.0 / intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  for (int v = 0; v < depth_mm.rows; ++v) {
    const auto* d = depth_mm.ptr<std::uint16_t>(v);
    auto* p = points.ptr<cv::Vec3f>(v);
    const float ry = (static_cast<float>(v) - cy) * inv_fy;
    for (int u = 0; u < depth_mm.cols; ++u) {
      if (d[u] == 0) {
        p[u] = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const float z = static_cast<float>(d[u]) * 0.001f;
      p[u] = cv::Vec3f((static_cast<float>(u) - cx) * inv_fx * z, ry * z, z);
    }
  }
  return points;
}

}  // namespace shapesense
