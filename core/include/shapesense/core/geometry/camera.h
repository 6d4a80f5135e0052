#pragma once
// Pinhole camera model shared by every layer.
//
// Conventions (see README): OpenCV camera frame, x right, y down, z forward, metres.
// Depth images are CV_16UC1 millimetres; 0 means "no reading".

#include <span>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace shapesense {

/// Pinhole intrinsics of the depth camera. Defaults are the Kinect v1 values.
struct CameraIntrinsics {
  double fx = 525.0;
  double fy = 525.0;
  double cx = 319.5;
  double cy = 239.5;
  int width = 640;
  int height = 480;

  /// The 3D point (metres) seen at pixel (u, v) with depth z (metres).
  Eigen::Vector3d backproject(double u, double v, double z) const {
    return {(u - cx) * z / fx, (v - cy) * z / fy, z};
  }
  /// The pixel (u, v) onto which a camera-frame point projects (z must be > 0).
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
  }
  /// Unit-z ray direction (x/z, y/z, 1) through pixel (u, v).
  Eigen::Vector3d ray(double u, double v) const { return {(u - cx) / fx, (v - cy) / fy, 1.0}; }

  bool operator==(const CameraIntrinsics&) const = default;
};

/// Kinect v1 structured-light noise model, used wherever a threshold must follow range.
/// One disparity step (1/8 px) of a sensor with focal*baseline `fb_px_m` spans
/// z^2 / (8 * fb) metres: 2.9 mm at 1 m, 2.6 cm at 3 m for the Kinect (fb ~ 43.5 px*m).
struct KinectNoiseModel {
  double focal_baseline_px_m = 43.5;  ///< focal length (px) times projector baseline (m)
  double disparity_step_px = 0.125;   ///< disparity quantisation of the sensor

  /// Depth quantisation step (metres) at range z (metres).
  double depthStep(double z) const { return z * z * disparity_step_px / focal_baseline_px_m; }
};

/// The pixels the camera-frame `points` in front of the camera (z >= 1 cm: nearer ones project
/// to nonsense) fall on, as the bounding rectangle clipped to the image; empty when none of
/// them is in front or the rectangle lies outside the image.
cv::Rect projectedBounds(std::span<const Eigen::Vector3d> points,
                         const CameraIntrinsics& intrinsics);

/// Converts a CV_16UC1 millimetre depth image to a CV_32FC3 image of camera-frame points in
/// metres; pixels without depth get NaN coordinates.
cv::Mat depthToPoints(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics);

}  // namespace shapesense
