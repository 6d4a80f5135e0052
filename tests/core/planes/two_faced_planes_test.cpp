// Step 4b of the Hough detector (two_faced_planes.h): a plane whose samples lie on two faces
// at a crease becomes two planes, each with the samples of its face; a plane on one face stays.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "../../../core/src/planes/two_faced_planes.h"
#include "face_scene.h"
#include "shapesense/core/geometry/camera.h"

namespace shapesense {
namespace {

using testing::Face;

// The two faces of a box corner pointing at the camera 2 m away, each 25 cm wide and turned
// 45 deg: within one plane's tolerance nowhere near, but the test below is given that plane.
std::vector<Face> corner() {
  const double h = std::sqrt(0.5);
  return {Face{{-h, 0, -h}, {0, 0, 2.0}, {-h, 0, h}, 0.25, 0.3},
          Face{{h, 0, -h}, {0, 0, 2.0}, {h, 0, h}, 0.25, 0.3}};
}

// The grid of a frame of `faces`, every sample on a face labelled as plane 0 of `planes`, the
// least-squares plane of those samples.
struct OnePlaneOverFaces {
  PlaneSampleGrid grid;
  cv::Mat face_of_sample;  // CV_8UC1: the frame's face image at each sample
  cv::Mat sample_labels;
  std::vector<PlaneHypothesis> planes;

  explicit OnePlaneOverFaces(const std::vector<Face>& faces) {
    const testing::FaceFrame frame = testing::renderFaces(faces, 4.0, 3);
    grid.build(frame.depth, CameraIntrinsics{}, 4);  // Kinect v1, as the frame
    sample_labels.create(grid.points.size(), CV_32SC1);
    face_of_sample.create(grid.points.size(), CV_8UC1);
    PlaneMoments moments;
    for (int r = 0; r < grid.points.rows; ++r)
      for (int c = 0; c < grid.points.cols; ++c) {
        const int face =
            frame.face.at<std::uint8_t>(grid.offset + r * grid.step, grid.offset + c * grid.step);
        const cv::Vec3f& p = grid.points.at<cv::Vec3f>(r, c);
        face_of_sample.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(face);
        const bool on_face = face != 0 && p[2] > 0;
        sample_labels.at<int>(r, c) = on_face ? 0 : -1;
        if (on_face) moments.add(Eigen::Vector3d(p[0], p[1], p[2]));
      }
    const PlaneFit fit = moments.fit();
    planes.push_back({fit.normal, fit.d});
  }
};

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, a.dot(b))) * 180.0 / M_PI;
}

TEST(TwoFacedPlanes, APlaneOverTwoFacesBecomesOnePerFace) {
  OnePlaneOverFaces scene(corner());
  splitTwoFacedPlanes(scene.grid, scene.sample_labels, scene.planes, HoughPlaneParams{});
  ASSERT_EQ(scene.planes.size(), 2u);
  // Each face's samples carry one plane, the plane within 2 deg of the face's.
  for (int face = 1; face <= 2; ++face) {
    int label = -2, samples = 0, others = 0;
    for (int r = 0; r < scene.grid.points.rows; ++r)
      for (int c = 0; c < scene.grid.points.cols; ++c) {
        if (scene.face_of_sample.at<std::uint8_t>(r, c) != face) continue;
        const int l = scene.sample_labels.at<int>(r, c);
        if (l < 0) continue;
        if (label == -2) label = l;
        ++(l == label ? samples : others);
      }
    ASSERT_GE(label, 0);
    EXPECT_GT(samples, 100);
    EXPECT_LE(others, samples / 20) << "face " << face;  // a sample or two at the crease
    EXPECT_LT(angleDeg(scene.planes[static_cast<std::size_t>(label)].normal,
                       corner()[static_cast<std::size_t>(face - 1)].normal),
              2.0);
  }
}

TEST(TwoFacedPlanes, APlaneOverOneFaceStays) {
  OnePlaneOverFaces scene({corner()[0]});
  const cv::Mat before = scene.sample_labels.clone();
  splitTwoFacedPlanes(scene.grid, scene.sample_labels, scene.planes, HoughPlaneParams{});
  EXPECT_EQ(scene.planes.size(), 1u);
  EXPECT_EQ(cv::countNonZero(scene.sample_labels != before), 0);
}

TEST(TwoFacedPlanes, NoSplitWhenTheTestIsOff) {
  OnePlaneOverFaces scene(corner());
  HoughPlaneParams off;
  off.two_face_gain = 0.0;
  splitTwoFacedPlanes(scene.grid, scene.sample_labels, scene.planes, off);
  EXPECT_EQ(scene.planes.size(), 1u);
}

}  // namespace
}  // namespace shapesense
