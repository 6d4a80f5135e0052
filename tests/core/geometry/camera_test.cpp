// The pinhole model's projections: a box's corners to the image rectangle they cover.

#include <gtest/gtest.h>

#include <vector>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {
namespace {

TEST(ProjectedBounds, CoversThePixelsOfThePointsInFrontClippedToTheImage) {
  const CameraIntrinsics k;  // Kinect v1: 525 px focal length, centre (319.5, 239.5)
  // A 20 cm square 1 m ahead, centred on the axis: 105 px across, about the centre.
  const std::vector<Eigen::Vector3d> square = {
      {-0.1, -0.1, 1.0}, {0.1, -0.1, 1.0}, {0.1, 0.1, 1.0}, {-0.1, 0.1, 1.0}};
  const cv::Rect bounds = projectedBounds(square, k);
  EXPECT_EQ(bounds.x, 267);       // floor(319.5 - 52.5)
  EXPECT_EQ(bounds.y, 187);       // floor(239.5 - 52.5)
  EXPECT_EQ(bounds.br().x, 373);  // ceil(319.5 + 52.5) + 1
  EXPECT_EQ(bounds.br().y, 293);

  // Reaching past the right edge: clipped there.
  std::vector<Eigen::Vector3d> wide = square;
  wide.emplace_back(2.0, 0.0, 1.0);
  EXPECT_EQ(projectedBounds(wide, k).br().x, k.width);

  // Points behind the camera, or at it, are left out; none in front gives nothing.
  std::vector<Eigen::Vector3d> with_behind = square;
  with_behind.emplace_back(0.5, 0.5, -1.0);
  with_behind.emplace_back(0.0, 0.0, 0.0);
  EXPECT_EQ(projectedBounds(with_behind, k), bounds);
  EXPECT_TRUE(projectedBounds(std::vector<Eigen::Vector3d>{{0.0, 0.0, -1.0}}, k).empty());

  // Wholly outside the image: empty.
  EXPECT_TRUE(
      projectedBounds(std::vector<Eigen::Vector3d>{{5.0, 0.0, 1.0}, {6.0, 0.0, 1.0}}, k).empty());
}

}  // namespace
}  // namespace shapesense
