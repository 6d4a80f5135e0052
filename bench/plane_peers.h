#pragma once
// Public peers of the plane detectors, run on the same depth frames and converted to our output
// (PlaneDetection: CV_16UC1 label image + one DetectedPlane per label, n towards the camera,
// d > 0) so that eval::scorePlanes scores them exactly like ours. Bench-only code: PCL and
// opencv_rgbd are linked into the benchmark executables only, never into shapesense.
//
// Every peer starts from the CV_16UC1 millimetre depth image, so its conversion to a point
// cloud (and its normals, where it needs them) is part of its time, as the depth-to-points work
// is part of ours.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/planes.h"

#ifdef SHAPESENSE_BENCH_OPENCV_RGBD
#include <opencv2/rgbd.hpp>
#endif

#ifdef SHAPESENSE_BENCH_PCL
#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/features/integral_image_normal.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/organized_multi_plane_segmentation.h>
#include <pcl/segmentation/sac_segmentation.h>
#endif

namespace shapesense::peers {

/// A plane (a, b, c, e) with a x + b y + c z + e = 0 in our convention: unit normal, d > 0
/// (the camera on the positive side). Peers differ in scale and sign conventions.
inline bool toOurPlane(double a, double b, double c, double e, DetectedPlane& out) {
  const double n = std::sqrt(a * a + b * b + c * c);
  if (!(n > 0) || !std::isfinite(e)) return false;
  const double s = (e < 0 ? -1.0 : 1.0) / n;
  out.normal = Eigen::Vector3d(a * s, b * s, c * s);
  out.d = e * s;
  return true;
}

/// Fills inliers and box of every plane from the label image and drops planes without pixels,
/// so that the output looks like ours to the scorer.
inline void finishDetection(PlaneDetection& det) {
  std::vector<std::size_t> count(det.planes.size() + 1, 0);
  std::vector<cv::Rect> box(det.planes.size() + 1);
  for (int v = 0; v < det.labels.rows; ++v) {
    const auto* p = det.labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < det.labels.cols; ++u) {
      const std::uint16_t l = p[u];
      if (!l || l > det.planes.size()) continue;
      box[l] = count[l]++ ? (box[l] | cv::Rect(u, v, 1, 1)) : cv::Rect(u, v, 1, 1);
    }
  }
  std::vector<DetectedPlane> kept;
  for (auto& p : det.planes) {
    p.inliers = count[p.id];
    p.box = box[p.id];
    if (p.inliers) kept.push_back(std::move(p));
  }
  det.planes = std::move(kept);
}

#ifdef SHAPESENSE_BENCH_OPENCV_RGBD
/// cv::rgbd::RgbdPlane with its own normals (cv::rgbd::RgbdNormals).
struct OpenCvRgbdPlaneParams {
  /// Normals: FALS (the fastest of OpenCV's accurate methods), 5x5 window. Defaults.
  int normals_method = cv::rgbd::RgbdNormals::RGBD_NORMALS_METHOD_FALS;
  int normals_window = 5;
  /// RgbdPlane's own defaults (block 40 px, threshold 1 cm) except min_size: 300 px, the
  /// smallest region our detectors keep (its default, block^2 = 1600 px, would drop surfaces the
  /// score counts, which start at 0.5% of the image = 1536 px).
  int block_size = 40;
  int min_size = 300;
  double threshold_m = 0.01;
  /// Quadratic sensor error a z^2, "0.0075 for a Kinect" per OpenCV's documentation.
  double sensor_error_a = 0.0075;
};

/// Keeps its normal estimator between frames, as a user processing a stream would.
class OpenCvRgbdPlaneDetector {
 public:
  OpenCvRgbdPlaneDetector(const CameraIntrinsics& K, OpenCvRgbdPlaneParams p = {})
      : K_(cv::Matx33f(static_cast<float>(K.fx), 0, static_cast<float>(K.cx), 0,
                       static_cast<float>(K.fy), static_cast<float>(K.cy), 0, 0, 1)),
        normals_(K.height, K.width, CV_32F, cv::Mat(K_), p.normals_window, p.normals_method),
        planes_(cv::rgbd::RgbdPlane::RGBD_PLANE_METHOD_DEFAULT, p.block_size, p.min_size,
                p.threshold_m, p.sensor_error_a) {}

  PlaneDetection detect(const cv::Mat& depth_mm) {
    cv::rgbd::depthTo3d(depth_mm, cv::Mat(K_), points_);  // mm -> m, no depth -> NaN
    normals_(points_, normals_out_);
    cv::Mat mask, coeffs;
    planes_(points_, normals_out_, mask, coeffs);
    PlaneDetection det;
    // mask: plane index per pixel, 255 = none; ours: index + 1, 0 = none.
    det.labels = cv::Mat::zeros(mask.size(), CV_16UC1);
    for (int v = 0; v < mask.rows; ++v) {
      const auto* m = mask.ptr<std::uint8_t>(v);
      auto* l = det.labels.ptr<std::uint16_t>(v);
      for (int u = 0; u < mask.cols; ++u)
        if (m[u] != 255) l[u] = static_cast<std::uint16_t>(m[u] + 1);
    }
    for (int i = 0; i < coeffs.rows; ++i) {
      const cv::Vec4f c = coeffs.at<cv::Vec4f>(i);
      DetectedPlane p;
      p.id = static_cast<std::uint16_t>(i + 1);
      p.group = i;
      if (toOurPlane(c[0], c[1], c[2], c[3], p)) det.planes.push_back(p);
    }
    finishDetection(det);
    return det;
  }

 private:
  cv::Matx33f K_;
  cv::rgbd::RgbdNormals normals_;
  cv::rgbd::RgbdPlane planes_;
  cv::Mat points_, normals_out_;
};
#endif  // SHAPESENSE_BENCH_OPENCV_RGBD

#ifdef SHAPESENSE_BENCH_PCL
/// Organized PCL cloud (width x height, NaN where there is no depth) from the depth image.
inline pcl::PointCloud<pcl::PointXYZ>::Ptr toPclCloud(const cv::Mat& depth_mm,
                                                      const CameraIntrinsics& K) {
  if (depth_mm.type() != CV_16UC1)
    throw std::invalid_argument("toPclCloud: depth must be CV_16UC1 millimetres");
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>(depth_mm.cols, depth_mm.rows);
  cloud->is_dense = false;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < depth_mm.rows; ++v) {
    const auto* d = depth_mm.ptr<std::uint16_t>(v);
    for (int u = 0; u < depth_mm.cols; ++u) {
      pcl::PointXYZ& p = (*cloud)(u, v);
      if (!d[u]) {
        p.x = p.y = p.z = nan;
        continue;
      }
      const float z = d[u] * 1e-3f;
      p.x = static_cast<float>((u - K.cx) / K.fx) * z;
      p.y = static_cast<float>((v - K.cy) / K.fy) * z;
      p.z = z;
    }
  }
  return cloud;
}

/// Sequential RANSAC with pcl::SACSegmentation: find the best plane among the remaining valid
/// points, remove its inliers, repeat. Plane inliers anywhere in the image belong to one plane,
/// so each plane's inlier mask is split into 8-connected regions (what a PCL user does with
/// Euclidean clustering of the inliers; on the organized cloud the image components are the
/// cheap equivalent) to yield one region per surface, as SegComp scoring expects.
struct PclSacParams {
  /// Inlier distance. Default 2 cm: PCL's tutorials use 1 cm, which Kinect noise (2.6 cm
  /// quantisation at 3 m) splits far planes with; 2 cm still separates a box top from a table.
  double distance_m = 0.02;
  /// Default 1000 (PCL's tutorials; RANSAC stops earlier when its 0.99 confidence is reached).
  int max_iterations = 1000;
  /// Stop when the best plane has fewer inliers. Default 1536 = 0.5% of VGA, the smallest
  /// surface the score counts.
  int min_plane_points = 1536;
  /// Default 30, as our RANSAC baseline.
  int max_planes = 30;
  /// Connected pieces smaller than this are dropped. Default 300 px, as our detectors.
  int min_region_pixels = 300;
};

inline PlaneDetection detectPlanesPclSac(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                         const PclSacParams& p = {}) {
  const auto cloud = toPclCloud(depth_mm, K);
  auto remaining = std::make_shared<pcl::Indices>();
  remaining->reserve(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i)
    if (std::isfinite((*cloud)[i].z)) remaining->push_back(static_cast<pcl::index_t>(i));

  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setOptimizeCoefficients(true);
  seg.setModelType(pcl::SACMODEL_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setDistanceThreshold(p.distance_m);
  seg.setMaxIterations(p.max_iterations);
  seg.setInputCloud(cloud);

  PlaneDetection det;
  det.labels = cv::Mat::zeros(depth_mm.size(), CV_16UC1);
  cv::Mat mask(depth_mm.size(), CV_8UC1), comp, stats, centroids;
  std::vector<char> taken(cloud->size(), 0);
  for (int k = 0; k < p.max_planes && static_cast<int>(remaining->size()) >= p.min_plane_points;
       ++k) {
    seg.setIndices(remaining);
    pcl::PointIndices inliers;
    pcl::ModelCoefficients coeff;
    seg.segment(inliers, coeff);
    if (static_cast<int>(inliers.indices.size()) < p.min_plane_points || coeff.values.size() != 4)
      break;
    DetectedPlane plane;
    if (!toOurPlane(coeff.values[0], coeff.values[1], coeff.values[2], coeff.values[3], plane))
      break;

    mask.setTo(0);
    for (const auto i : inliers.indices) {
      taken[i] = 1;
      mask.at<std::uint8_t>(static_cast<int>(i) / depth_mm.cols,
                            static_cast<int>(i) % depth_mm.cols) = 255;
    }
    const int n = cv::connectedComponentsWithStats(mask, comp, stats, centroids, 8, CV_32S);
    std::vector<std::uint16_t> id_of(n, 0);
    for (int c = 1; c < n; ++c) {
      if (stats.at<int>(c, cv::CC_STAT_AREA) < p.min_region_pixels || det.planes.size() >= 65534)
        continue;
      plane.id = static_cast<std::uint16_t>(det.planes.size() + 1);
      plane.group = k;
      id_of[c] = plane.id;
      det.planes.push_back(plane);
    }
    for (int v = 0; v < comp.rows; ++v) {
      const int* c = comp.ptr<int>(v);
      auto* l = det.labels.ptr<std::uint16_t>(v);
      for (int u = 0; u < comp.cols; ++u)
        if (c[u] && id_of[c[u]]) l[u] = id_of[c[u]];
    }
    std::erase_if(*remaining, [&](pcl::index_t i) { return taken[i] != 0; });
  }
  finishDetection(det);
  return det;
}

/// pcl::IntegralImageNormalEstimation then pcl::OrganizedMultiPlaneSegmentation with its
/// refinement (segmentAndRefine), the pipeline of PCL's organized segmentation demo.
struct PclOmpsParams {
  /// Normals as in PCL's organized segmentation demo: covariance matrix, 1 cm max depth change
  /// factor, 20 px smoothing. Defaults.
  pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal>::NormalEstimationMethod
      normal_method =
          pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal>::COVARIANCE_MATRIX;
  float max_depth_change_factor = 0.01f;
  float normal_smoothing_size = 20.0f;
  /// Segmentation as in the demo (2 deg, 2 cm) except min_inliers: default 1000 (the demo's
  /// 10000 would drop most surfaces the score counts, which start at 1536 px).
  unsigned min_inliers = 1000;
  double angular_threshold_deg = 2.0;
  double distance_m = 0.02;
};

/// Keeps its estimators between frames, as a user processing a stream would.
class PclOmpsDetector {
 public:
  explicit PclOmpsDetector(PclOmpsParams p = {}) {
    ne_.setNormalEstimationMethod(p.normal_method);
    ne_.setMaxDepthChangeFactor(p.max_depth_change_factor);
    ne_.setNormalSmoothingSize(p.normal_smoothing_size);
    mps_.setMinInliers(p.min_inliers);
    mps_.setAngularThreshold(p.angular_threshold_deg * M_PI / 180.0);
    mps_.setDistanceThreshold(p.distance_m);
  }

  /// The normals step alone (for the segmentation benchmark).
  pcl::PointCloud<pcl::Normal>::Ptr normals(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud) {
    auto out = std::make_shared<pcl::PointCloud<pcl::Normal>>();
    ne_.setInputCloud(cloud);
    ne_.compute(*out);
    return out;
  }

  /// The segmentation step alone, on normals of the same cloud.
  PlaneDetection segment(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud,
                         const pcl::PointCloud<pcl::Normal>::ConstPtr& normals) {
    mps_.setInputCloud(cloud);
    mps_.setInputNormals(normals);
    std::vector<pcl::PlanarRegion<pcl::PointXYZ>,
                Eigen::aligned_allocator<pcl::PlanarRegion<pcl::PointXYZ>>>
        regions;
    std::vector<pcl::ModelCoefficients> coeffs;
    std::vector<pcl::PointIndices> inliers, label_indices, boundary_indices;
    auto labels = std::make_shared<pcl::PointCloud<pcl::Label>>();
    mps_.segmentAndRefine(regions, coeffs, inliers, labels, label_indices, boundary_indices);

    PlaneDetection det;
    det.labels =
        cv::Mat::zeros(static_cast<int>(cloud->height), static_cast<int>(cloud->width), CV_16UC1);
    auto* l = det.labels.ptr<std::uint16_t>(0);
    for (std::size_t k = 0; k < coeffs.size() && k < inliers.size() && k < 65535; ++k) {
      DetectedPlane p;
      p.id = static_cast<std::uint16_t>(det.planes.size() + 1);
      p.group = static_cast<int>(k);
      const auto& c = coeffs[k].values;
      if (c.size() != 4 || !toOurPlane(c[0], c[1], c[2], c[3], p)) continue;
      for (const auto i : inliers[k].indices) l[i] = p.id;
      det.planes.push_back(p);
    }
    finishDetection(det);
    return det;
  }

  PlaneDetection detect(const cv::Mat& depth_mm, const CameraIntrinsics& K) {
    const auto cloud = toPclCloud(depth_mm, K);
    return segment(cloud, normals(cloud));
  }

 private:
  pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> ne_;
  pcl::OrganizedMultiPlaneSegmentation<pcl::PointXYZ, pcl::Normal, pcl::Label> mps_;
};
#endif  // SHAPESENSE_BENCH_PCL

}  // namespace shapesense::peers
