// The SIMD kernels of segmentation on every target this machine can run (forEachSimdTarget).
//
// The depth-step edge strength (the image depth_step's watershed floods) against a textbook
// reference written from its definition: the 2x2 reduction to working resolution (the mean of
// the block's readings within 3 quantisation steps of its nearest one) and, per pixel, the count
// of window neighbours with a reading whose depth differs by more than the ring's threshold.
// The kernels compute both a vector of pixels per step with a one-pixel path at the borders; the
// inputs here reach every path of every vector width: widths 1-41, 70 and 640, all window radii,
// both resolutions, holes, depth steps and readings up to 65535 mm.
//
// The flood seeds and the upsampling are checked through whole segmentations: every method's
// labels are the same bits on every target.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/driver/synthetic_scene.h"
#include "simd_targets.h"

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

void expectReferenceEdges(const std::string& target) {
  SCOPED_TRACE(target);
  std::mt19937 rng(11);
  const CameraIntrinsics intrinsics;
  int compared = 0;
  for (int cols : {1, 2, 3, 7, 8, 9, 15, 16, 17, 18, 19, 20, 23, 24, 31, 33, 40, 41, 70, 640}) {
    for (int rows : {1, 2, 5, 12}) {
      const cv::Mat depth = randomDepth(rows, cols, rng);
      for (int ds : {1, 2}) {
        for (int r = 1; r <= 7; ++r) {
          SCOPED_TRACE(::testing::Message() << cols << "x" << rows << " ds " << ds << " r " << r);
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

TEST(SegmentationKernels, DepthStepEdgesEqualTheReferenceOnEveryTargetPathAndWindowRadius) {
  testing::forEachSimdTarget(expectReferenceEdges);
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}

// Depth images that reach every path: synthetic rooms, random noise with holes at odd sizes
// (row tails shorter than any vector), and both resolutions.
std::vector<cv::Mat> kernelInputs() {
  std::vector<cv::Mat> inputs;
  for (std::uint64_t seed : {1, 2}) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    sp.render_colour = false;
    inputs.push_back(synthetic::SyntheticScene(sp).render(0, 0).frame.depth);
  }
  std::mt19937 rng(5);
  for (cv::Size size : {cv::Size(3, 3), cv::Size(37, 21), cv::Size(70, 33), cv::Size(161, 97)})
    inputs.push_back(randomDepth(size.height, size.width, rng));
  return inputs;
}

// Calls outputs(emit) on every SIMD target this machine runs; emit(output, what) keeps each
// output of the first target and expects the same bits, in the same order, on every other.
// Returns the number of targets.
template <typename Outputs>
int expectSameOnEveryTarget(const Outputs& outputs) {
  std::vector<cv::Mat> first;
  std::string first_target;
  int targets = 0;
  testing::forEachSimdTarget([&](const std::string& target) {
    ++targets;
    std::size_t k = 0;
    outputs([&](const cv::Mat& output, const std::string& what) {
      if (first_target.empty())
        first.push_back(output);
      else if (k >= first.size())
        ADD_FAILURE() << target << " gives more outputs than " << first_target;
      else
        EXPECT_TRUE(same(output, first[k]))
            << target << " differs from " << first_target << ": " << what;
      ++k;
    });
    if (first_target.empty()) first_target = target;
  });
  return targets;
}

std::string describe(const cv::Mat& depth, int ds) {
  return "ds " + std::to_string(ds) + " on a " + std::to_string(depth.cols) + "x" +
         std::to_string(depth.rows) + " image";
}

// plane_prediction's edge strength (its gradient and anomaly-count kernels) is the same on
// every target, at both resolutions, on inputs narrower than a vector and with holes.
TEST(SegmentationKernels, PlanePredictionEdgesAreTheSameOnEveryTarget) {
  const std::vector<cv::Mat> inputs = kernelInputs();
  const CameraIntrinsics intrinsics;
  const int targets = expectSameOnEveryTarget([&](const auto& emit) {
    for (const cv::Mat& depth : inputs)
      for (int ds : {1, 2}) {
        SegmentationParams params;
        params.plane_prediction.region.downsample = ds;
        emit(segmentationEdgeStrength(depth, intrinsics, SegmentationMethod::kPlanePrediction,
                                      params),
             describe(depth, ds));
      }
  });
  EXPECT_GE(targets, 1);
}

TEST(SegmentationKernels, EveryMethodGivesTheSameLabelsOnEveryTarget) {
  const std::vector<cv::Mat> inputs = kernelInputs();
  const CameraIntrinsics intrinsics;
  const int targets = expectSameOnEveryTarget([&](const auto& emit) {
    for (const cv::Mat& depth : inputs)
      for (SegmentationMethod method : kSegmentationMethods)
        for (int ds : {1, 2}) {
          SegmentationParams params;
          params.depth_step.region.downsample = params.normal_edges.region.downsample =
              params.fused.region.downsample = params.plane_prediction.region.downsample =
                  params.tiled_ransac.region.downsample = ds;
          emit(segmentDepth(depth, intrinsics, method, params),
               std::string(formatSegmentationMethod(method)) + " " + describe(depth, ds));
        }
  });
  EXPECT_GE(targets, 1);
}

}  // namespace
}  // namespace shapesense
