#include "normals/normal_input.h"

#include "normals/normal_kernels.h"

namespace shapesense::detail {
namespace {

void loadDepth(const cv::Mat& depth, const CameraIntrinsics& intr, NormalInput& input) {
  const float inv_fx = static_cast<float>(1.0 / intr.fx),
              inv_fy = static_cast<float>(1.0 / intr.fy);
  const float cx = static_cast<float>(intr.cx), cy = static_cast<float>(intr.cy);
  input.ray_x.resize(static_cast<std::size_t>(input.cols));
  for (int u = 0; u < input.cols; ++u) input.ray_x[u] = (static_cast<float>(u) - cx) * inv_fx;
  input.ray_y.resize(static_cast<std::size_t>(input.rows));
  for (int v = 0; v < input.rows; ++v) input.ray_y[v] = (static_cast<float>(v) - cy) * inv_fy;
  input.from_depth = true;
  input.points_built = false;
  for (int v = 0; v < input.rows; ++v)
    depthRowToZ(depth.ptr<std::uint16_t>(v), input.cols,
                input.z.data() + std::size_t(v) * input.cols);
}

void loadPoints(const cv::Mat& points, NormalInput& input) {
  points.copyTo(input.points);
  input.from_depth = false;
  for (int v = 0; v < input.rows; ++v) {
    const auto* p = input.points.ptr<cv::Vec3f>(v);
    float* z = input.z.data() + static_cast<std::size_t>(v) * input.cols;
    for (int u = 0; u < input.cols; ++u) z[u] = p[u][2];
  }
}

}  // namespace

void loadInput(const cv::Mat& depth_or_points, const CameraIntrinsics& intrinsics,
               NormalInput& input) {
  CV_Assert(depth_or_points.type() == CV_16UC1 || depth_or_points.type() == CV_32FC3);
  input.rows = depth_or_points.rows;
  input.cols = depth_or_points.cols;
  input.z.resize(static_cast<std::size_t>(input.rows) * input.cols);
  if (depth_or_points.type() == CV_16UC1)
    loadDepth(depth_or_points, intrinsics, input);
  else
    loadPoints(depth_or_points, input);
}

void buildPoints(NormalInput& input) {
  if (!input.from_depth || input.points_built) return;
  input.points_built = true;
  input.points.create(input.rows, input.cols, CV_32FC3);
  for (int v = 0; v < input.rows; ++v)
    pointsRow(input.zRow(v), input.ray_x.data(), input.ray_y[v], input.cols,
              input.points.ptr<float>(v));
}

}  // namespace shapesense::detail
