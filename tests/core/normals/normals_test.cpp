// Integral-image normals on analytic scenes rendered with Kinect-like disparity quantisation.
#include "shapesense/core/normals/normals.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "normal_test_frames.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

using normaltest::kinectQuantise;
using normaltest::name;

constexpr double kPi = 3.14159265358979323846;

// Plane n.X + d = 0 (n unit, facing the camera) rendered into a depth image.
cv::Mat renderPlane(const Eigen::Vector3d& n, double d, const CameraIntrinsics& K,
                    double noise_steps, unsigned seed = 1) {
  std::mt19937 rng(seed);
  cv::Mat depth(K.height, K.width, CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const double t = -d / n.dot(K.ray(u, v));
      if (t > 0.3 && t < 6.0) depth.at<std::uint16_t>(v, u) = kinectQuantise(t, noise_steps, rng);
    }
  }
  return depth;
}

Eigen::Vector3d tiltedNormal(double rx_deg, double ry_deg) {
  const double ax = rx_deg * kPi / 180.0, ay = ry_deg * kPi / 180.0;
  // Start facing the camera (0, 0, -1) and rotate about x then y.
  Eigen::Vector3d n(0, 0, -1);
  n = Eigen::Vector3d(n.x(), std::cos(ax) * n.y() - std::sin(ax) * n.z(),
                      std::sin(ax) * n.y() + std::cos(ax) * n.z());
  n = Eigen::Vector3d(std::cos(ay) * n.x() + std::sin(ay) * n.z(), n.y(),
                      -std::sin(ay) * n.x() + std::cos(ay) * n.z());
  return n.normalized();
}

struct ErrorStats {
  double median_deg = 180;
  double p90_deg = 180;
  double valid_fraction = 0;
};

// Angular error over the central 60% of the image.
ErrorStats angularError(const cv::Mat& normals, const Eigen::Vector3d& truth) {
  std::vector<double> err;
  int total = 0;
  for (int v = normals.rows / 5; v < normals.rows * 4 / 5; ++v) {
    for (int u = normals.cols / 5; u < normals.cols * 4 / 5; ++u) {
      ++total;
      const cv::Vec3f n = normals.at<cv::Vec3f>(v, u);
      if (std::isnan(n[0])) continue;
      const double c = std::clamp(
          static_cast<double>(n[0] * truth.x() + n[1] * truth.y() + n[2] * truth.z()), -1.0, 1.0);
      err.push_back(std::acos(c) * 180.0 / kPi);
    }
  }
  ErrorStats s;
  s.valid_fraction = static_cast<double>(err.size()) / total;
  if (err.empty()) return s;
  std::sort(err.begin(), err.end());
  s.median_deg = err[err.size() / 2];
  s.p90_deg = err[err.size() * 9 / 10];
  return s;
}

TEST(Normals, TiltedPlaneEachModeMatchesTruth) {
  const CameraIntrinsics K;
  const Eigen::Vector3d n = tiltedNormal(25.0, -35.0);
  for (double range : {1.0, 2.0}) {
    // Plane through (0, 0, range).
    const double d = -n.dot(Eigen::Vector3d(0, 0, range));
    const cv::Mat depth = renderPlane(n, d, K, 0.3);
    for (auto m : {NormalMethod::kCovariance, NormalMethod::kAverage3dGradient,
                   NormalMethod::kAverageDepthChange}) {
      NormalParams p;
      p.method = m;
      const ErrorStats e = angularError(computeNormals(depth, K, p), n);
      std::printf("[normals] %-22s range %.1f m: median %.2f deg, p90 %.2f deg, valid %.3f\n",
                  name(m), range, e.median_deg, e.p90_deg, e.valid_fraction);
      EXPECT_GT(e.valid_fraction, 0.95) << name(m) << " at " << range;
      const double tol = m == NormalMethod::kCovariance
                             ? 2.0
                             : (m == NormalMethod::kAverage3dGradient ? 2.5 : 4.0);
      EXPECT_LT(e.median_deg, tol) << name(m) << " at " << range;
      EXPECT_LT(e.p90_deg, 2 * tol) << name(m) << " at " << range;
    }
  }
}

TEST(Normals, PointsInputMatchesDepthInput) {
  const CameraIntrinsics K;
  const Eigen::Vector3d n = tiltedNormal(10.0, 30.0);
  const cv::Mat depth = renderPlane(n, -n.dot(Eigen::Vector3d(0, 0, 1.5)), K, 0.3);
  for (auto m : {NormalMethod::kCovariance, NormalMethod::kAverage3dGradient,
                 NormalMethod::kAverageDepthChange}) {
    NormalParams p;
    p.method = m;
    const cv::Mat a = computeNormals(depth, K, p);
    const cv::Mat b = computeNormals(depthToPoints(depth, K), K, p);
    int mismatches = 0;
    for (int v = 0; v < a.rows; ++v)
      for (int u = 0; u < a.cols; ++u) {
        const cv::Vec3f x = a.at<cv::Vec3f>(v, u), y = b.at<cv::Vec3f>(v, u);
        if (std::isnan(x[0]) != std::isnan(y[0]))
          ++mismatches;
        else if (!std::isnan(x[0]) && cv::norm(x - y) > 1e-4)
          ++mismatches;
      }
    EXPECT_EQ(mismatches, 0) << name(m);
  }
}

// For depth input the point image is built on demand (the gradient modes do not use it): points()
// still returns z times the pixel rays, NaN without depth, after any mode.
TEST(Normals, PointsOfDepthInputOnDemand) {
  const CameraIntrinsics K;
  const Eigen::Vector3d n = tiltedNormal(10.0, 30.0);
  cv::Mat depth = renderPlane(n, -n.dot(Eigen::Vector3d(0, 0, 1.5)), K, 0.3);
  depth(cv::Rect(10, 20, 5, 5)).setTo(0);
  for (auto m : {NormalMethod::kAverage3dGradient, NormalMethod::kCovariance}) {
    NormalParams p;
    p.method = m;
    NormalEstimator est(p);
    cv::Mat normals;
    est.compute(depth, K, normals);
    const cv::Mat& pts = est.points();
    ASSERT_EQ(pts.type(), CV_32FC3);
    ASSERT_EQ(pts.size(), depth.size());
    for (int v = 0; v < depth.rows; v += 7)
      for (int u = 0; u < depth.cols; u += 5) {
        const cv::Vec3f x = pts.at<cv::Vec3f>(v, u);
        const std::uint16_t d = depth.at<std::uint16_t>(v, u);
        if (d == 0) {
          EXPECT_TRUE(std::isnan(x[2])) << u << ", " << v;
          continue;
        }
        const float z = static_cast<float>(d) * 0.001f;
        EXPECT_EQ(x[2], z) << u << ", " << v;
        EXPECT_NEAR(x[0], (u - K.cx) / K.fx * z, 1e-5) << u << ", " << v;
        EXPECT_NEAR(x[1], (v - K.cy) / K.fy * z, 1e-5) << u << ", " << v;
      }
  }
}

// A square 30 cm in front of a fronto-parallel wall: normals must never straddle the step (a
// window over both surfaces tilts the normal by tens of degrees; small windows next to the step
// are merely noisy, so the bound is 35 deg) and the pixels at the step are invalid.
TEST(Normals, InvalidAcrossDepthStepAndWithoutDepth) {
  const CameraIntrinsics K;
  std::mt19937 rng(3);
  cv::Mat depth(K.height, K.width, CV_16UC1);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const bool front = u >= 200 && u < 440 && v >= 140 && v < 340;
      depth.at<std::uint16_t>(v, u) = kinectQuantise(front ? 1.0 : 1.3, 0.3, rng);
    }
  // A hole.
  depth(cv::Rect(50, 50, 20, 20)).setTo(0);
  for (auto m : {NormalMethod::kCovariance, NormalMethod::kAverage3dGradient,
                 NormalMethod::kAverageDepthChange}) {
    NormalParams p;
    p.method = m;
    const cv::Mat normals = computeNormals(depth, K, p);
    int straddling = 0, valid = 0;
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const cv::Vec3f n = normals.at<cv::Vec3f>(v, u);
        if (std::isnan(n[0])) continue;
        ++valid;
        if (-n[2] < std::cos(35.0 * kPi / 180.0)) ++straddling;
      }
    EXPECT_EQ(straddling, 0) << name(m);
    EXPECT_GT(valid, K.width * K.height * 0.8) << name(m);
    // Pixels on both sides of the step and inside the hole are invalid.
    for (int v = 150; v < 330; v += 7) {
      EXPECT_TRUE(std::isnan(normals.at<cv::Vec3f>(v, 199)[0]) ||
                  std::isnan(normals.at<cv::Vec3f>(v, 200)[0]))
          << v;
      EXPECT_TRUE(std::isnan(normals.at<cv::Vec3f>(v, 198)[0]) &&
                  std::isnan(normals.at<cv::Vec3f>(v, 201)[0]))
          << v;
    }
    for (int v = 50; v < 70; ++v)
      for (int u = 50; u < 70; ++u) ASSERT_TRUE(std::isnan(normals.at<cv::Vec3f>(v, u)[0]));
    // ... but pixels next to the hole keep a normal (holes are not steps).
    EXPECT_FALSE(std::isnan(normals.at<cv::Vec3f>(60, 72)[0])) << name(m);
  }
}

}  // namespace
}  // namespace shapesense
