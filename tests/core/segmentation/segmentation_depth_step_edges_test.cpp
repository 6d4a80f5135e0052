// The depth-step edge strength (the image depth_step's watershed floods) against a textbook
// reference written from its definition: the 2x2 reduction to working resolution (the mean of
// the block's readings within 3 quantisation steps of its nearest one) and, per pixel, the count
// of window neighbours with a reading whose depth differs by more than the ring's threshold.
// The library computes both eight (four) pixels per SIMD step with a one-pixel path at the
// borders; the inputs here reach every path: widths 1-41 and 640, all window radii, both
// resolutions, holes, depth steps and readings up to 65535 mm.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense {
namespace {

cv::Mat referenceReduction(const cv::Mat& depth, const KinectNoiseModel& noise) {
  if (depth.rows < 2 || depth.cols < 2) return depth.clone();
  const float k =
      static_cast<float>(3.0 * noise.disparity_step_px / noise.focal_baseline_px_m * 1e-3);
  cv::Mat out(depth.rows / 2, depth.cols / 2, CV_16UC1);
  for (int v = 0; v < out.rows; ++v) {
    for (int u = 0; u < out.cols; ++u) {
      const std::uint16_t q[4] = {
          depth.at<std::uint16_t>(2 * v, 2 * u), depth.at<std::uint16_t>(2 * v, 2 * u + 1),
          depth.at<std::uint16_t>(2 * v + 1, 2 * u), depth.at<std::uint16_t>(2 * v + 1, 2 * u + 1)};
      unsigned nearest = 0xFFFF;  // as the library: a lone 65535 reading counts as none
      for (auto x : q)
        if (x != 0) nearest = std::min<unsigned>(nearest, x);
      if (nearest == 0xFFFF) {
        out.at<std::uint16_t>(v, u) = 0;
        continue;
      }
      const float nf = static_cast<float>(nearest);
      const unsigned limit = nearest + static_cast<unsigned>(k * nf * nf) + 1;
      unsigned sum = 0, n = 0;
      for (auto x : q) {
        if (x != 0 && x <= limit) {
          sum += x;
          ++n;
        }
      }
      out.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>((sum + n / 2) / n);
    }
  }
  return out;
}

cv::Mat referenceEdges(const cv::Mat& d, const DepthStepParams& p, const KinectNoiseModel& noise,
                       int ds) {
  const float step_k = static_cast<float>(p.noise_steps * noise.disparity_step_px /
                                          noise.focal_baseline_px_m * 1e-3);
  const float slope = static_cast<float>(p.slope_factor * ds);
  const float min_t = static_cast<float>(p.min_threshold_mm);
  const int r = p.window_radius;
  cv::Mat edges(d.size(), CV_8UC1);
  for (int v = 0; v < d.rows; ++v) {
    for (int u = 0; u < d.cols; ++u) {
      const std::uint16_t x = d.at<std::uint16_t>(v, u);
      const float z = static_cast<float>(x);
      int count = 0;
      for (int dv = -r; dv <= r; ++dv) {
        for (int du = -r; du <= r; ++du) {
          const int vq = v + dv, uq = u + du;
          if ((du == 0 && dv == 0) || vq < 0 || vq >= d.rows || uq < 0 || uq >= d.cols) continue;
          const std::uint16_t y = d.at<std::uint16_t>(vq, uq);
          const float ring = static_cast<float>(std::max(std::abs(du), std::abs(dv)));
          const float th = std::max(min_t, step_k * z * z + slope * ring * z);
          const auto t = static_cast<std::uint16_t>(std::min(th, 65535.0f));
          const int diff = std::abs(static_cast<int>(x) - static_cast<int>(y));
          count += y != 0 && diff > t;
        }
      }
      edges.at<std::uint8_t>(v, u) = x == 0 ? 255 : static_cast<std::uint8_t>(count);
    }
  }
  return edges;
}

// Surfaces at 0.5-4.5 m with depth steps, noise, holes, and some readings near 65535 mm.
cv::Mat randomDepth(int rows, int cols, std::mt19937& rng) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  cv::Mat depth(rows, cols, CV_16UC1);
  const float base = 500.0f + 4000.0f * unit(rng), slope = 40.0f * (unit(rng) - 0.5f);
  const int step_at = static_cast<int>(unit(rng) * static_cast<float>(cols));
  for (int v = 0; v < rows; ++v) {
    for (int u = 0; u < cols; ++u) {
      float z = base + slope * static_cast<float>(u + v) + 30.0f * unit(rng);
      if (u >= step_at) z -= 300.0f;
      const float pick = unit(rng);
      if (pick < 0.15f) z = 0.0f;                          // hole
      if (pick > 0.97f) z = 65535.0f - 20.0f * unit(rng);  // far outlier
      depth.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::clamp(z, 0.0f, 65535.0f));
    }
  }
  return depth;
}

TEST(DepthStepEdges, EqualTheReferenceOnEveryPathAndWindowRadius) {
  std::mt19937 rng(11);
  const CameraIntrinsics intrinsics;
  int compared = 0;
  for (int cols : {1, 2, 3, 7, 8, 9, 15, 16, 17, 18, 19, 20, 23, 24, 31, 33, 40, 41, 640}) {
    for (int rows : {1, 2, 5, 12}) {
      const cv::Mat depth = randomDepth(rows, cols, rng);
      for (int ds : {1, 2}) {
        for (int r = 1; r <= 7; ++r) {
          SCOPED_TRACE(testing::Message() << cols << "x" << rows << " ds " << ds << " r " << r);
          SegmentationParams params;
          params.depth_step.window_radius = r;
          params.depth_step.region.downsample = ds;
          const KinectNoiseModel& noise = params.depth_step.region.noise;
          const cv::Mat edges =
              segmentationEdgeStrength(depth, intrinsics, SegmentationMethod::kDepthStep, params);
          const bool reduced = ds == 2 && rows >= 2 && cols >= 2;
          const cv::Mat working = reduced ? referenceReduction(depth, noise) : depth;
          const cv::Mat expected =
              referenceEdges(working, params.depth_step, noise, reduced ? 2 : 1);
          ASSERT_EQ(edges.size(), expected.size());
          ASSERT_EQ(cv::countNonZero(edges != expected), 0);
          compared += static_cast<int>(edges.total());
        }
      }
    }
  }
  EXPECT_GT(compared, 100'000);
}

}  // namespace
}  // namespace shapesense
