#include "shapesense/core/geometry/camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace shapesense {

cv::Rect projectedBounds(std::span<const Eigen::Vector3d> points,
                         const CameraIntrinsics& intrinsics) {
  constexpr double kNearestZ = 0.01;
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  bool any = false;
  for (const Eigen::Vector3d& point : points) {
    if (!(point.z() >= kNearestZ)) continue;
    const Eigen::Vector2d pixel = intrinsics.project(point);
    x0 = std::min(x0, pixel.x());
    y0 = std::min(y0, pixel.y());
    x1 = std::max(x1, pixel.x());
    y1 = std::max(y1, pixel.y());
    any = true;
  }
  if (!any) return {};
  const cv::Rect image(0, 0, intrinsics.width, intrinsics.height);
  const auto clamp = [](double value) { return static_cast<int>(std::clamp(value, -1e6, 1e6)); };
  const cv::Point tl(clamp(std::floor(x0)), clamp(std::floor(y0)));
  const cv::Point br(clamp(std::ceil(x1)) + 1, clamp(std::ceil(y1)) + 1);
  return cv::Rect(tl, br) & image;
}

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
