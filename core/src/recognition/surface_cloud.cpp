#include "shapesense/core/recognition/surface_cloud.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include <Eigen/Eigenvalues>

#include "cloud_index.h"

namespace shapesense {
namespace {

// One point per voxel: the mean of its points and of their normals (renormalised). Normals may
// be empty; then only the points are thinned.
SurfaceCloud thinToVoxels(const std::vector<Eigen::Vector3f>& points,
                          const std::vector<Eigen::Vector3f>& normals, float voxel) {
  const std::vector<detail::CellEntry> keyed = detail::pointsByCell(points, voxel);
  SurfaceCloud out;
  out.points.reserve(keyed.size());
  if (!normals.empty()) out.normals.reserve(keyed.size());
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin;
    Eigen::Vector3f point_sum = Eigen::Vector3f::Zero();
    Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
    while (end < keyed.size() && keyed[end].key == keyed[begin].key) {
      point_sum += points[keyed[end].index];
      if (!normals.empty()) normal_sum += normals[keyed[end].index];
      ++end;
    }
    out.points.push_back(point_sum / static_cast<float>(end - begin));
    if (!normals.empty()) {
      const float norm = normal_sum.norm();
      if (norm > 1e-6f) {
        out.normals.push_back(normal_sum / norm);
      } else {
        out.points.pop_back();  // opposite normals in one voxel: a sheet seen from both sides
      }
    }
    begin = end;
  }
  return out;
}

// Smallest principal axis of each point's neighbourhood; points with too few neighbours go.
SurfaceCloud estimateNormals(const SurfaceCloud& thinned, const SurfaceCloudParams& params) {
  std::vector<Eigen::Vector3f> normals(thinned.size(), Eigen::Vector3f::Zero());
  const detail::PointGrid grid(thinned.points, params.normal_radius_m);
  grid.forEachPoint(params.normal_radius_m, {}, [&](std::uint32_t i, const auto& neighbours) {
    if (static_cast<int>(neighbours.size()) < params.min_normal_neighbours) return;
    Eigen::Vector3f mean = Eigen::Vector3f::Zero();
    for (std::uint32_t j : neighbours) mean += thinned.points[j];
    mean /= static_cast<float>(neighbours.size());
    Eigen::Matrix3f covariance = Eigen::Matrix3f::Zero();
    for (std::uint32_t j : neighbours) {
      const Eigen::Vector3f d = thinned.points[j] - mean;
      covariance += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver(covariance);
    normals[i] = solver.eigenvectors().col(0).normalized();
  });
  SurfaceCloud out;
  for (std::size_t i = 0; i < thinned.size(); ++i) {
    if (normals[i].isZero()) continue;
    out.points.push_back(thinned.points[i]);
    out.normals.push_back(normals[i]);
  }
  return out;
}

void faceViewpoint(SurfaceCloud& cloud, const Eigen::Vector3f& viewpoint) {
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.normals[i].dot(viewpoint - cloud.points[i]) < 0.0f)
      cloud.normals[i] = -cloud.normals[i];
}

}  // namespace

SurfaceCloud surfaceCloudFromDepth(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                   const cv::Mat& mask, const SurfaceCloudParams& params) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  CV_Assert(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == depth_mm.size()));
  const cv::Mat normal_image = computeNormals(depth_mm, intrinsics, params.normals);
  const int stride = std::max(1, params.pixel_stride);
  std::vector<Eigen::Vector3f> points, normals;
  const std::size_t read = static_cast<std::size_t>((depth_mm.rows + stride - 1) / stride) *
                           static_cast<std::size_t>((depth_mm.cols + stride - 1) / stride);
  points.reserve(read);
  normals.reserve(read);
  for (int v = 0; v < depth_mm.rows; v += stride) {
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    const auto* normal = normal_image.ptr<cv::Vec3f>(v);
    const auto* keep = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < depth_mm.cols; u += stride) {
      if (depth[u] == 0 || (keep && keep[u] == 0) || std::isnan(normal[u][0])) continue;
      const float z = 1e-3f * static_cast<float>(depth[u]);
      if (z > params.max_range_m) continue;
      points.push_back(intrinsics.backproject(u, v, z).cast<float>());
      normals.emplace_back(normal[u][0], normal[u][1], normal[u][2]);
    }
  }
  SurfaceCloud cloud = thinToVoxels(points, normals, params.voxel_m);
  faceViewpoint(cloud, Eigen::Vector3f::Zero());
  return cloud;
}

SurfaceCloud surfaceCloudFromPoints(const std::vector<Eigen::Vector3f>& points,
                                    const std::vector<Eigen::Vector3f>& normals,
                                    const Eigen::Vector3f& viewpoint,
                                    const SurfaceCloudParams& params) {
  CV_Assert(normals.empty() || normals.size() == points.size());
  std::vector<Eigen::Vector3f> finite_points, finite_normals;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    if (!normals.empty() && (!normals[i].allFinite() || normals[i].norm() < 1e-6f)) continue;
    finite_points.push_back(points[i]);
    if (!normals.empty()) finite_normals.push_back(normals[i].normalized());
  }
  SurfaceCloud cloud = thinToVoxels(finite_points, finite_normals, params.voxel_m);
  if (normals.empty()) cloud = estimateNormals(cloud, params);
  faceViewpoint(cloud, viewpoint);
  return cloud;
}

}  // namespace shapesense
