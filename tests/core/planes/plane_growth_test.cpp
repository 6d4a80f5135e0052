// The labelling's last step (plane_growth.h): pixels of a plane's surface that no sample reached
// join the plane beside them, and nothing else does: not a board proud of it (even within the
// plane's tolerance: a depth step parts them), not pixels past a blocked band, not pixels off a
// plane turned away from the surface.
#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../../../core/src/planes/plane_growth.h"
#include "face_scene.h"

namespace shapesense {
namespace {

using testing::Face;

constexpr double kWallM = 1.5;
constexpr std::uint16_t kWallId = 1;

// A wall 1.5 m ahead with a board 5 cm proud of it (about eight depth steps there), read with
// the Kinect's noise; the wall's plane found only on the image's left quarter.
struct WallScene {
  cv::Mat depth;  // CV_16UC1 mm
  cv::Mat board;  // CV_8UC1, non-zero on the board
  PlaneDetection detection;

  WallScene() {
    const Face board_face{Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0.05, 0.0, kWallM - 0.05),
                          Eigen::Vector3d(1, 0, 0), 0.2, 0.1};
    const testing::FaceFrame frame = testing::renderFaces({board_face}, kWallM, 3);
    depth = frame.depth;
    board = frame.face;
    DetectedPlane wall;
    wall.id = kWallId;
    wall.normal = Eigen::Vector3d(0, 0, -1);
    wall.d = kWallM;
    detection.planes.push_back(wall);
    detection.labels = cv::Mat::zeros(depth.size(), CV_16UC1);
    detection.labels(cv::Rect(0, 0, depth.cols / 4, depth.rows)).setTo(kWallId);
    detection.labels.setTo(0, depth == 0);
    detection.planes[0].inliers = static_cast<std::size_t>(cv::countNonZero(detection.labels));
    detection.planes[0].box = cv::boundingRect(detection.labels != 0);
  }

  // The wall's tolerance: 1.5 of the sensor's depth steps (about 1 cm at 1.5 m), or
  // `tolerance_steps` of them.
  std::size_t grow(const cv::Mat& blocked = cv::Mat(), double tolerance_steps = 1.5) {
    const KinectNoiseModel noise;
    const std::vector<float> tolerance_at_1m = {
        0.0f, static_cast<float>(tolerance_steps * noise.depthStep(1.0))};
    DepthStepRule continuity;
    return labeling::growPlanesIntoUnlabelled(depth, CameraIntrinsics{}, tolerance_at_1m, 0.004f,
                                              continuity, blocked, detection);
  }

  cv::Mat wallWithDepth() const { return (board == 0) & (depth != 0); }
};

TEST(PlaneGrowth, TheRestOfTheSurfaceJoinsItsPlaneAndTheBoardProudOfItDoesNot) {
  WallScene scene;
  const int before = cv::countNonZero(scene.detection.labels);
  const std::size_t taken = scene.grow();
  const cv::Mat labelled = scene.detection.labels == kWallId;
  const cv::Mat wall = scene.wallWithDepth();
  const int wall_pixels = cv::countNonZero(wall);
  const int wall_labelled = cv::countNonZero(labelled & wall);
  EXPECT_GE(wall_labelled, 0.99 * wall_pixels) << wall_labelled << " of " << wall_pixels;
  EXPECT_EQ(cv::countNonZero(labelled & (scene.board != 0)), 0);
  EXPECT_EQ(static_cast<int>(taken), cv::countNonZero(labelled) - before);
  EXPECT_EQ(scene.detection.planes[0].inliers,
            static_cast<std::size_t>(cv::countNonZero(labelled)));
  EXPECT_EQ(scene.detection.planes[0].box, cv::boundingRect(labelled));
}

TEST(PlaneGrowth, BlockedPixelsAreNotTakenNorGrownThrough) {
  WallScene scene;
  cv::Mat blocked = cv::Mat::zeros(scene.depth.size(), CV_8UC1);
  const int band = scene.depth.cols / 2;
  blocked.colRange(band, band + 2).setTo(1);
  scene.grow(blocked);
  const cv::Mat labelled = scene.detection.labels == kWallId;
  EXPECT_EQ(cv::countNonZero(labelled.colRange(band, labelled.cols)), 0);
  const cv::Mat left_wall = scene.wallWithDepth().colRange(0, band);
  EXPECT_GE(cv::countNonZero(labelled.colRange(0, band) & left_wall),
            0.99 * cv::countNonZero(left_wall));
}

TEST(PlaneGrowth, ADepthStepStopsItWhereTheToleranceWouldNot) {
  WallScene scene;
  scene.grow(cv::Mat(), 10.0);  // 6.5 cm at 1.5 m: the board 5 cm proud lies within it
  const cv::Mat labelled = scene.detection.labels == kWallId;
  EXPECT_EQ(cv::countNonZero(labelled & (scene.board != 0)), 0);
  const cv::Mat wall = scene.wallWithDepth();
  EXPECT_GE(cv::countNonZero(labelled & wall), 0.99 * cv::countNonZero(wall));
}

TEST(PlaneGrowth, PixelsOffThePlaneStayOut) {
  WallScene scene;
  // The plane turned 5 deg about the image's vertical axis through the wall's left quarter: the
  // wall leaves its tolerance a few centimetres to the right of where the labels end.
  const double angle = 5.0 * M_PI / 180.0;
  const double pivot_x =
      (scene.depth.cols / 4 - CameraIntrinsics{}.cx) / CameraIntrinsics{}.fx * kWallM;
  DetectedPlane& plane = scene.detection.planes[0];
  plane.normal = Eigen::Vector3d(-std::sin(angle), 0.0, -std::cos(angle));
  plane.d = -plane.normal.dot(Eigen::Vector3d(pivot_x, 0.0, kWallM));
  scene.grow();
  const cv::Mat labelled = scene.detection.labels == kWallId;
  const cv::Mat wall = scene.wallWithDepth();
  const int right_half = scene.depth.cols / 2;
  EXPECT_GT(cv::countNonZero(labelled.colRange(scene.depth.cols / 4, right_half)), 0);
  EXPECT_EQ(cv::countNonZero(labelled.colRange(right_half, labelled.cols)), 0);
  EXPECT_LT(cv::countNonZero(labelled & wall), 0.6 * cv::countNonZero(wall));
}

}  // namespace
}  // namespace shapesense
