// The plane detector on a noisy sensor at range: the depth-step rule of its sample normals
// follows the frame's measured noise (NormalParams::depth_change_noise_sigmas, set for the sample
// normals).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "face_scene.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {
namespace {

// The far end of a room: a wall 4 m ahead between two side walls 1.5 m to either side, read
// with 0.15 px of disparity noise (the noisiest sensor of the evaluation's scenes: 5.5 cm of
// depth noise at that range).
testing::FaceFrame noisyFarWall() {
  using testing::Face;
  const std::vector<Face> side_walls = {Face{{1, 0, 0}, {-1.5, 0, 0.5}, {0, 0, 1}, 3.5, 5.0},
                                        Face{{-1, 0, 0}, {1.5, 0, 0.5}, {0, 0, 1}, 3.5, 5.0}};
  return testing::renderFaces(side_walls, 4.0, 5, 0.15);
}

// The plane found on the far wall (normal within 5 deg of the wall's; a pointer into the
// detection it was found in) and the share of the wall's pixels it holds; none: share 0.
struct WallPlane {
  const DetectedPlane* plane = nullptr;
  double share = 0.0;
};

WallPlane wallPlane(const PlaneDetection& detection, const cv::Mat& face) {
  const double cos_5deg = std::cos(5.0 * M_PI / 180.0);
  WallPlane out;
  const int wall_pixels = cv::countNonZero(face == 0);
  for (const DetectedPlane& p : detection.planes) {
    if (-p.normal.z() < cos_5deg) continue;
    const int on_wall = cv::countNonZero((detection.labels == p.id) & (face == 0));
    const double share = static_cast<double>(on_wall) / wall_pixels;
    if (share > out.share) out = {&p, share};
  }
  return out;
}

TEST(NoisySensor, AFarWallIsOnePlane) {
  const testing::FaceFrame frame = noisyFarWall();
  HoughPlaneDetector detector;  // defaults
  const PlaneDetection detection = detector.detect(frame.depth, CameraIntrinsics{});
  const WallPlane wall = wallPlane(detection, frame.face);  // points into `detection`
  ASSERT_NE(wall.plane, nullptr) << "no plane on the wall";
  EXPECT_GE(wall.share, 0.9);
  // Tolerances: 1 deg, and 2 cm of d (the depth noise at 4 m is 5.5 cm a reading).
  EXPECT_LT(std::acos(std::min(1.0, -wall.plane->normal.z())) * 180.0 / M_PI, 1.0);
  EXPECT_NEAR(wall.plane->d, 4.0, 0.02);
}

TEST(NoisySensor, WithTheFixedStepRuleTheWallIsLost) {
  const testing::FaceFrame frame = noisyFarWall();
  HoughPlaneParams params;
  params.normals.depth_change_noise_sigmas = 0.0;
  HoughPlaneDetector detector(params);
  EXPECT_LT(wallPlane(detector.detect(frame.depth, CameraIntrinsics{}), frame.face).share, 0.5);
}

}  // namespace
}  // namespace shapesense
