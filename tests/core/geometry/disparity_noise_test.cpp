// disparityNoisePx: the disparity noise of a frame, measured from its depth, against the noise
// the frame was read with.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "face_scene.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/disparity_noise.h"

namespace shapesense {
namespace {

// A plane turned 30 deg about the vertical, 2 m ahead at the image centre, read by the Kinect v1
// with `sigma_px` of disparity noise; every `step`-th pixel, as the plane detector samples.
cv::Mat tiltedPlaneDepth(double sigma_px, int step, unsigned seed) {
  const CameraIntrinsics K;
  const Eigen::Vector3d normal(std::sin(M_PI / 6), 0.0, -std::cos(M_PI / 6));
  const double d = -normal.dot(Eigen::Vector3d(0, 0, 2.0));
  std::mt19937 rng(seed);
  cv::Mat depth(K.height / step, K.width / step, CV_16UC1);
  for (int r = 0; r < depth.rows; ++r)
    for (int c = 0; c < depth.cols; ++c) {
      const Eigen::Vector3d ray = K.ray(c * step, r * step);
      const double z = -d / normal.dot(ray);  // the ray's z is 1
      depth.at<std::uint16_t>(r, c) = testing::kinectDepthMm(z, rng, sigma_px);
    }
  return depth;
}

// The quantisation (1/8 px) adds its own variance, step^2 / 12, to the noise drawn.
double readNoisePx(double sigma_px) {
  const double step = KinectNoiseModel{}.disparity_step_px;
  return std::sqrt(sigma_px * sigma_px + step * step / 12);
}

TEST(DisparityNoise, MeasuresTheNoiseOfAFrameWithinTenPercent) {
  for (const double sigma : {0.05, 0.1, 0.15})
    for (const int step : {1, 4}) {
      const double measured = disparityNoisePx(tiltedPlaneDepth(sigma, step, 7));
      EXPECT_NEAR(measured, readNoisePx(sigma), 0.1 * readNoisePx(sigma))
          << "sigma " << sigma << " px, step " << step;
    }
}

TEST(DisparityNoise, DepthEdgesAreNotNoise) {
  cv::Mat depth = tiltedPlaneDepth(0.07, 1, 9);
  const double plane_only = disparityNoisePx(depth);
  // A box 1 m ahead, read with the same noise, over a third of the columns: its two edges on
  // every row are steps of about 20 px, which would double the mean.
  std::mt19937 rng(11);
  for (int r = 0; r < depth.rows; ++r)
    for (int c = 200; c < 420; ++c)
      depth.at<std::uint16_t>(r, c) = testing::kinectDepthMm(1.0, rng);
  EXPECT_NEAR(disparityNoisePx(depth), plane_only, 0.1 * plane_only);
}

TEST(DisparityNoise, NoReadingsNoMeasure) {
  EXPECT_EQ(disparityNoisePx(cv::Mat()), 0.0);
  EXPECT_EQ(disparityNoisePx(cv::Mat::zeros(480, 640, CV_16UC1)), 0.0);
}

}  // namespace
}  // namespace shapesense
