// The labelling's crease step (PlaneLabelingParams::crease_* and minor_face_*): a plane gives
// back the strip it took of a neighbouring face that was not found as a plane, a region on two
// faces gives back the smaller, and each keeps its own pixels, on frames with the Kinect's
// disparity noise and quantisation.
#include <array>
#include <cmath>
#include <cstdint>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "face_scene.h"
#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense {
namespace {

using testing::Face;

enum class Truth : std::uint8_t { kBackground, kFront, kSide };

// A leg 10 cm wide and 5 cm deep with its convex edge 1.5 m ahead, turned so that the camera
// sees its front at 27 deg and its side at 63 deg, before a wall at 3 m.
struct LegScene {
  Face front, side;
  cv::Mat depth;  // CV_16UC1 mm, with the sensor's noise
  cv::Mat truth;  // CV_8UC1 Truth

  LegScene() {
    const Eigen::Vector3d edge(0.0, 0.0, 1.5);
    const Eigen::Vector3d front_normal = Eigen::Vector3d(-0.5, 0.0, -1.0).normalized();
    const Eigen::Vector3d front_along = Eigen::Vector3d(-1.0, 0.0, 0.5).normalized();
    front = {front_normal, edge, front_along, 0.10};
    side = {-front_along, edge, -front_normal, 0.05};
    // Face i + 1 of the render is Truth's value for it.
    testing::FaceFrame frame = testing::renderFaces({front, side}, 3.0, 7);
    depth = frame.depth;
    truth = frame.face;
  }

  // Labels with the front face as the only plane (its samples labelled, the side left to the
  // labelling's growth), as a detector that did not find the narrow side gives them.
  PlaneDetection labelFrontOnly(const PlaneLabelingParams& params) const {
    const CameraIntrinsics K;  // Kinect v1
    PlaneSampleGrid grid;
    grid.build(depth, K, params.sample_step);
    cv::Mat sample_labels(grid.points.size(), CV_32SC1);
    for (int r = 0; r < grid.points.rows; ++r)
      for (int c = 0; c < grid.points.cols; ++c) {
        const int u = grid.offset + c * grid.step, v = grid.offset + r * grid.step;
        sample_labels.at<int>(r, c) =
            truth.at<std::uint8_t>(v, u) == static_cast<std::uint8_t>(Truth::kFront) ? 0 : -1;
      }
    return labelPlanes(depth, K, cv::Mat(), grid, sample_labels, {front.plane()}, params);
  }
};

struct Shares {
  double front_kept = 0.0;  // of the front's pixels, the share labelled
  double side_taken = 0.0;  // of the side's pixels, the share labelled (with the front's plane)
  int front_pixels = 0;
  int front_rows = 0;  // image rows the front spans (the crease's length in pixels)
};

Shares sharesOf(const LegScene& scene, const PlaneDetection& out) {
  int front = 0, front_labelled = 0, side = 0, side_labelled = 0, front_rows = 0;
  for (int v = 0; v < scene.truth.rows; ++v) {
    const int front_before_row = front;
    for (int u = 0; u < scene.truth.cols; ++u) {
      const bool labelled = out.labels.at<std::uint16_t>(v, u) != 0;
      switch (static_cast<Truth>(scene.truth.at<std::uint8_t>(v, u))) {
        case Truth::kFront:
          ++front, front_labelled += labelled;
          break;
        case Truth::kSide:
          ++side, side_labelled += labelled;
          break;
        case Truth::kBackground:
          break;
      }
    }
    front_rows += front > front_before_row;
  }
  return {static_cast<double>(front_labelled) / front, static_cast<double>(side_labelled) / side,
          front, front_rows};
}

TEST(CreaseStrips, APlaneGivesBackTheStripItTookOfAnUnfoundNeighbour) {
  const LegScene scene;
  PlaneLabelingParams without;
  without.crease_max_passes = 0;
  const Shares before = sharesOf(scene, scene.labelFrontOnly(without));
  const Shares after = sharesOf(scene, scene.labelFrontOnly(PlaneLabelingParams{}));
  // Without the step the front's tolerance takes a strip of the side (what the step is for).
  ASSERT_GT(before.side_taken, 0.15);
  // With it, at most a third of that strip stays (the pixels nearest the crease, where the two
  // surfaces are within the noise of each other)...
  EXPECT_LT(after.side_taken, before.side_taken / 3.0)
      << "side taken " << before.side_taken << " -> " << after.side_taken;
  // ...and the front keeps its own pixels but a rim along the crease at most 2 px wide.
  const double rim = 2.0 * before.front_rows / before.front_pixels;
  EXPECT_GT(after.front_kept, before.front_kept - rim)
      << "front kept " << before.front_kept << " -> " << after.front_kept << " (rim " << rim << ")";
}

// A plane with no crease (a floor seen at a grazing angle, holes in it) loses none of its
// pixels: its boundary's windows average out to the plane, and holes add no readings.
TEST(CreaseStrips, AGrazingNoisyPlaneWithHolesKeepsItsPixels) {
  const CameraIntrinsics K;  // Kinect v1
  // A floor 0.8 m below the camera, seen from 1.2 m to 4 m.
  const PlaneHypothesis floor{Eigen::Vector3d(0.0, -1.0, 0.0), 0.8};
  cv::Mat depth(K.height, K.width, CV_16UC1);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector3d ray = K.ray(u, v);
      const double z = ray.y() > 1e-6 ? 0.8 / ray.y() : 0.0;
      if (z < 1.2 || z > 4.0 || unit(rng) < 0.03) {
        depth.at<std::uint16_t>(v, u) = 0;
        continue;
      }
      depth.at<std::uint16_t>(v, u) = testing::kinectDepthMm(z, rng);
    }
  auto labelled = [&](const PlaneLabelingParams& params) {
    PlaneSampleGrid grid;
    grid.build(depth, K, params.sample_step);
    cv::Mat sample_labels(grid.points.size(), CV_32SC1);
    for (int r = 0; r < grid.points.rows; ++r)
      for (int c = 0; c < grid.points.cols; ++c)
        sample_labels.at<int>(r, c) = grid.depth_mm.at<std::uint16_t>(r, c) ? 0 : -1;
    const PlaneDetection out =
        labelPlanes(depth, K, cv::Mat(), grid, sample_labels, {floor}, params);
    return cv::countNonZero(out.labels);
  };
  PlaneLabelingParams without;
  without.crease_max_passes = 0;
  const int before = labelled(without), after = labelled(PlaneLabelingParams{});
  ASSERT_GT(before, 50000);
  EXPECT_GE(after, 0.995 * before) << before << " -> " << after;
}

// The shares of a larger and a smaller face labelled (before a wall 4 m ahead), when the
// samples of both are labelled as one region with the plane `between` them, as one hypothesis
// between two faces labels them far off, where both lie within its tolerance.
struct FaceShares {
  double larger = 0.0, smaller = 0.0;
};
FaceShares sharesLabelled(const Face& larger, const Face& smaller, const PlaneHypothesis& between,
                          const PlaneLabelingParams& params) {
  const testing::FaceFrame frame = testing::renderFaces({larger, smaller}, 4.0, 5);
  const CameraIntrinsics K;  // Kinect v1
  PlaneSampleGrid grid;
  grid.build(frame.depth, K, params.sample_step);
  cv::Mat sample_labels(grid.points.size(), CV_32SC1);
  for (int row = 0; row < grid.points.rows; ++row)
    for (int c = 0; c < grid.points.cols; ++c) {
      const int u = grid.offset + c * grid.step, v = grid.offset + row * grid.step;
      sample_labels.at<int>(row, c) = frame.face.at<std::uint8_t>(v, u) != 0 ? 0 : -1;
    }
  const PlaneDetection out =
      labelPlanes(frame.depth, K, cv::Mat(), grid, sample_labels, {between}, params);
  std::array<double, 3> labelled{}, all{};  // by face: 1 larger, 2 smaller
  for (int v = 0; v < frame.face.rows; ++v)
    for (int u = 0; u < frame.face.cols; ++u) {
      const int face = frame.face.at<std::uint8_t>(v, u);
      all[face] += 1.0;
      labelled[face] += out.labels.at<std::uint16_t>(v, u) != 0;
    }
  return {labelled[1] / all[1], labelled[2] / all[2]};
}

// Without the step the region holds both faces (what the step is for); with it, the smaller
// goes but for pixels where the two lie within the noise of each other, and the larger stays.
void expectSmallerFaceGivenBack(const Face& larger, const Face& smaller,
                                const PlaneHypothesis& between) {
  PlaneLabelingParams without;
  without.minor_face_gain = 0.0;
  const FaceShares before = sharesLabelled(larger, smaller, between, without);
  const FaceShares after = sharesLabelled(larger, smaller, between, PlaneLabelingParams{});
  ASSERT_GT(before.smaller, 0.8);
  ASSERT_GT(before.larger, 0.8);
  EXPECT_LT(after.smaller, 0.2) << before.smaller << " -> " << after.smaller;
  EXPECT_GT(after.larger, 0.9 * before.larger) << before.larger << " -> " << after.larger;
}

// A box's edge 2.5 m ahead, pointing at the camera: a face 7 cm wide to its left and one 3.5 cm
// wide to its right, each at 45 deg to the line of sight, with the plane z = 2.5 m between them
// (both within its tolerance of 3 depth steps, 5 cm).
TEST(CreaseStrips, ARegionOnTwoFacesAtACreaseGivesBackTheSmaller) {
  const Eigen::Vector3d edge(0.0, 0.0, 2.5);
  const double r = std::sqrt(0.5);
  const Face larger{Eigen::Vector3d(-r, 0.0, -r), edge, Eigen::Vector3d(-r, 0.0, r), 0.07};
  const Face smaller{Eigen::Vector3d(r, 0.0, -r), edge, Eigen::Vector3d(r, 0.0, r), 0.035};
  expectSmallerFaceGivenBack(larger, smaller, {Eigen::Vector3d(0.0, 0.0, -1.0), 2.5});
}

// Two faces facing the camera side by side, 40 cm wide 1.5 m ahead and 20 cm wide 3 cm behind
// it (5 of the sensor's depth steps there), with the plane midway between them (both within its
// tolerance of 3 steps, 1.9 cm): two touching boxes' fronts. (Narrower, the step between them
// bends a quadric enough for the curvature check to drop the region whole.)
TEST(CreaseStrips, ARegionOnTwoParallelFacesTheSensorTellsApartGivesBackTheSmaller) {
  const Eigen::Vector3d facing(0.0, 0.0, -1.0), across(1.0, 0.0, 0.0);
  const Face larger{facing, Eigen::Vector3d(-0.4, 0.0, 1.5), across, 0.4};
  const Face smaller{facing, Eigen::Vector3d(0.0, 0.0, 1.53), across, 0.2};
  expectSmallerFaceGivenBack(larger, smaller, {facing, 1.515});
}

}  // namespace
}  // namespace shapesense
