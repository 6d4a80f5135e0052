// The normals' Highway kernels on every SIMD target this machine runs, against the scalar target
// (EMU128 / SCALAR: the kernels' one-lane-at-a-time definition): the same bits at every pixel.
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "normal_test_frames.h"
#include "shapesense/core/normals/normals.h"
#include "shapesense/driver/synthetic_scene.h"
#include "simd_targets.h"

namespace shapesense {
namespace {

using normaltest::kinectQuantise;
using normaltest::name;

bool isScalarTarget(const std::string& target) { return target == "EMU128" || target == "SCALAR"; }

// Expects every target's output to equal the scalar target's bit for bit; returns the scalar
// output.
cv::Mat expectSameAsScalar(const std::map<std::string, cv::Mat>& by_target,
                           const std::string& what) {
  cv::Mat scalar;
  bool found_scalar = false;
  for (const auto& [target, out] : by_target)
    if (isScalarTarget(target)) {
      scalar = out;
      found_scalar = true;
    }
  EXPECT_TRUE(found_scalar) << what << ": no scalar target";
  for (const auto& [target, out] : by_target) {
    if (isScalarTarget(target)) continue;
    EXPECT_EQ(out.size(), scalar.size()) << what << " " << target;
    if (out.size() != scalar.size() || scalar.empty()) continue;
    int differ = 0;
    for (int v = 0; v < out.rows; ++v)
      for (int u = 0; u < out.cols; ++u) {
        const auto* x = &out.at<cv::Vec3f>(v, u);
        const auto* y = &scalar.at<cv::Vec3f>(v, u);
        if (std::memcmp(x, y, sizeof *x) != 0 && differ++ < 5)
          ADD_FAILURE() << what << " " << target << " (" << u << ", " << v << ")";
      }
    EXPECT_EQ(differ, 0) << what << " " << target;
  }
  return scalar;
}

// Runs `compute` once per target and expects every target's output to equal the scalar
// target's; returns the scalar output.
template <typename Compute>
cv::Mat expectSameOnEveryTarget(const Compute& compute, const std::string& what) {
  std::map<std::string, cv::Mat> by_target;
  testing::forEachSimdTarget(
      [&](const std::string& target) { by_target[target] = compute().clone(); });
  return expectSameAsScalar(by_target, what);
}

// Frames that make the window radius vary (range-scaled radius, clipped by depth steps, holes
// and the image border): synthetic scenes, a steep ramp (the radius changes every few pixels)
// with steps and holes, widths that are no multiple of any vector width, and a view into a
// larger image (rows not contiguous).
struct TestFrame {
  cv::Mat depth;
  CameraIntrinsics intrinsics;
};

std::vector<TestFrame> radiusVaryingFrames() {
  const CameraIntrinsics K;
  std::vector<TestFrame> frames;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    synthetic::SceneParams p;
    p.seed = seed;
    p.render_colour = false;
    frames.push_back({synthetic::SyntheticScene(p).render(0, 0).frame.depth.clone(), K});
  }
  std::mt19937 rng(7);
  cv::Mat ramp(K.height, K.width, CV_16UC1);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      double z = 0.5 + 3.5 * u / K.width + 0.3 * v / K.height;  // radius 2..20 across the image
      if ((u / 37 + v / 29) % 5 == 0) z += 0.25;                // depth steps
      ramp.at<std::uint16_t>(v, u) = kinectQuantise(z, 0.5, rng);
    }
  for (int i = 0; i < 400; ++i) {  // scattered holes of 1-4 pixels
    const int u = static_cast<int>(rng() % K.width), v = static_cast<int>(rng() % K.height);
    ramp(cv::Rect(u, v, 1 + static_cast<int>(rng() % 4), 1) & cv::Rect(0, 0, K.width, K.height))
        .setTo(0);
  }
  frames.push_back({ramp, K});
  const cv::Rect crop(3, 5, 317, 233);
  CameraIntrinsics k = K;
  k.cx -= crop.x;
  k.cy -= crop.y;
  k.width = crop.width;
  k.height = crop.height;
  frames.push_back({ramp(crop).clone(), k});
  frames.push_back({frames[0].depth(crop), k});
  return frames;
}

TEST(NormalKernels, EveryTargetMatchesScalarOnRadiusVaryingFrames) {
  const std::vector<TestFrame> frames = radiusVaryingFrames();
  for (bool depth_dependent : {true, false}) {
    for (auto m : {NormalMethod::kCovariance, NormalMethod::kAverage3dGradient,
                   NormalMethod::kAverageDepthChange}) {
      NormalParams p;
      p.method = m;
      p.depth_dependent_smoothing = depth_dependent;
      NormalEstimator est(p);
      for (std::size_t f = 0; f < frames.size(); ++f) {
        const std::string what = std::string(name(m)) + " frame " + std::to_string(f) +
                                 (depth_dependent ? "" : " fixed radius");
        cv::Mat out;
        const cv::Mat scalar = expectSameOnEveryTarget(
            [&]() -> const cv::Mat& {
              est.compute(frames[f].depth, frames[f].intrinsics, out);
              return out;
            },
            what);
        int valid = 0;
        for (int i = 0; i < scalar.rows * scalar.cols; ++i)
          valid += !std::isnan(scalar.at<cv::Vec3f>(i)[0]);
        EXPECT_GT(valid, scalar.cols * scalar.rows / 4) << what;
        // Point input: the points of the depth input, on every target too.
        const cv::Mat points = est.points().clone();
        expectSameOnEveryTarget(
            [&]() -> const cv::Mat& {
              est.compute(points, frames[f].intrinsics, out);
              return out;
            },
            what + " points");
      }
    }
  }
}

// Any frame size, down to one row or one column: an output of the input's size, NaN where no
// window fits, and every target equal to the scalar one. One estimator serves frames of
// alternating sizes and both input types.
TEST(NormalKernels, AnySizeAndAlternatingSizesAndInputTypes) {
  const CameraIntrinsics K;
  std::mt19937 rng(11);
  cv::Mat full(K.height, K.width, CV_16UC1);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u)
      full.at<std::uint16_t>(v, u) = kinectQuantise(0.8 + 2.0 * u / K.width, 0.5, rng);
  const std::vector<cv::Size> sizes = {{0, 0},   {0, 240},   {240, 0}, {1, 1},    {1, 480},
                                       {640, 1}, {2, 2},     {3, 3},   {7, 5},    {8, 9},
                                       {9, 8},   {15, 17},   {16, 16}, {17, 15},  {33, 2},
                                       {2, 33},  {640, 480}, {31, 29}, {640, 480}};
  for (auto m : {NormalMethod::kCovariance, NormalMethod::kAverage3dGradient,
                 NormalMethod::kAverageDepthChange}) {
    NormalParams p;
    p.method = m;
    NormalEstimator est(p);
    for (const cv::Size& size : sizes) {
      const cv::Mat depth = full(cv::Rect(0, 0, size.width, size.height));
      CameraIntrinsics k = K;
      k.width = size.width;
      k.height = size.height;
      for (const bool as_points : {false, true}) {
        cv::Mat input = depth;
        if (as_points) {
          cv::Mat unused;
          est.compute(depth, k, unused);
          input = size.empty() ? cv::Mat(size, CV_32FC3) : est.points().clone();
        }
        std::ostringstream what;
        what << name(m) << " " << size << (as_points ? " points" : " depth");
        cv::Mat out;
        const cv::Mat want = expectSameOnEveryTarget(
            [&]() -> const cv::Mat& {
              est.compute(input, k, out);
              return out;
            },
            what.str());
        if (size.empty()) {  // OpenCV may store an empty size as 0 x 0
          EXPECT_TRUE(want.empty()) << what.str();
          continue;
        }
        ASSERT_EQ(want.size(), size) << what.str();
        ASSERT_EQ(want.type(), CV_32FC3);
        // Smallest frame side a window fits in: the covariance window is centred on the pixel
        // (2r + 1), the gradient modes' four windows reach one pixel further (2r + 3).
        const int fits = 2 * p.min_radius_px + (m == NormalMethod::kCovariance ? 1 : 3);
        if (size.width < fits || size.height < fits) {
          int valid = 0;
          for (int i = 0; i < size.area(); ++i) valid += !std::isnan(want.at<cv::Vec3f>(i)[0]);
          EXPECT_EQ(valid, 0) << what.str() << ": no window fits";
        }
      }
    }
  }
}

}  // namespace
}  // namespace shapesense
