// Boxes from segments standing on planes, against synthetic ground truth.

#include <gtest/gtest.h>

#include "shapesense/core/boxes/object_boxes.h"
#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  return inter / (a.area() + b.area() - inter);
}

TEST(ObjectBoxes, ObjectsOnTheTableGetBoxesAndStructureDoesNot) {
  int objects = 0, found = 0, boxes_total = 0, boxes_matched = 0;
  HoughPlaneDetector planes_detector;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    synthetic::SceneParams params;
    params.seed = seed;
    params.render_colour = false;
    const auto rendered = synthetic::SyntheticScene(params).render(0, 1);
    const Frame& frame = rendered.frame;
    const cv::Mat segments =
        segmentDepth(frame.depth, frame.intrinsics, SegmentationMethod::kFused);
    const auto statistics = computeSegmentStatistics(segments, frame.depth, frame.intrinsics);
    const auto planes = planes_detector.detect(frame.depth, frame.intrinsics);
    const auto boxes =
        boxesOfObjectsOnPlanes(frame.depth, frame.intrinsics, segments, statistics, planes);
    boxes_total += static_cast<int>(boxes.size());
    for (const auto& box : boxes) {
      for (const auto& object : rendered.truth.objects) {
        if (object.kind != "table" && iou(box.roi, object.image_box) >= 0.5) {
          ++boxes_matched;
          break;
        }
      }
    }
    for (const auto& object : rendered.truth.objects) {
      if (object.kind == "table" || object.pixel_count < 400) continue;
      ++objects;
      for (const auto& box : boxes) {
        if (iou(box.roi, object.image_box) >= 0.5) {
          ++found;
          // The box lies where the object is: its centre within 10 cm + half the object's size.
          Eigen::Vector3d centre = Eigen::Vector3d::Zero();
          for (const auto& c : box.box.corners) centre += c / 8.0;
          EXPECT_LT((centre - object.center).norm(), 0.10 + 0.5 * object.size.norm())
              << object.name;
          break;
        }
      }
    }
  }
  std::printf("[object boxes] %d of %d visible objects boxed; %d of %d boxes match an object\n",
              found, objects, boxes_matched, boxes_total);
  ASSERT_GT(objects, 20);
  // Measured on seeds 1-6 (fused segmentation, Hough planes): 18 of 42 objects boxed, 18 of 25
  // boxes on an object. Floors just below; the misses are objects whose faces the segmentation
  // merges with a neighbour touching them without a depth step (a box behind a bowl).
  EXPECT_GE(static_cast<double>(found) / objects, 0.38);
  EXPECT_GE(static_cast<double>(boxes_matched) / std::max(1, boxes_total), 0.65);
}

// An object whose foot is hidden, in most columns, by a box standing in front of it: that box's
// front face is the first plane below the object there, but the object is behind that plane, not
// on it. The table, reached below the object's other columns, is its support.
TEST(ObjectBoxes, AFaceInFrontOfTheFootIsNotTheSupport) {
  CameraIntrinsics k;
  k.fx = k.fy = 100.0;
  k.cx = k.cy = 50.0;
  k.width = k.height = 100;
  const cv::Rect object(20, 20, 60, 30), occluder(20, 50, 40, 20);
  cv::Mat depth(100, 100, CV_16UC1, cv::Scalar(1500));
  depth(occluder).setTo(1200);
  cv::Mat segment_labels(100, 100, CV_16UC1, cv::Scalar(3));  // 3: the table and the rest
  segment_labels(object).setTo(1);
  segment_labels(occluder).setTo(2);
  PlaneDetection planes;
  planes.labels = cv::Mat::zeros(100, 100, CV_16UC1);
  planes.labels(cv::Rect(0, 50, 100, 50)).setTo(2);  // the table below the object
  planes.labels(occluder).setTo(1);
  planes.planes.resize(2);
  planes.planes[0].id = 1;  // the occluder's front face, z = 1.2 m
  planes.planes[0].normal = {0.0, 0.0, -1.0};
  planes.planes[0].d = 1.2;
  planes.planes[1].id = 2;  // the table, 0.3 m below the camera
  planes.planes[1].normal = {0.0, -1.0, 0.0};
  planes.planes[1].d = 0.3;
  const auto segments = computeSegmentStatistics(segment_labels, depth, k);
  const DetectedPlane* support = supportPlaneBelow(depth, segment_labels, segments, planes, {1});
  ASSERT_NE(support, nullptr);
  EXPECT_EQ(support->id, 2);
}

TEST(ObjectBoxes, NoPlanesMeansNoBoxes) {
  synthetic::SceneParams params;
  params.render_colour = false;
  const auto rendered = synthetic::SyntheticScene(params).render(0, 1);
  const Frame& frame = rendered.frame;
  const cv::Mat segments = segmentDepth(frame.depth, frame.intrinsics, SegmentationMethod::kFused);
  PlaneDetection none;
  none.labels = cv::Mat::zeros(frame.depth.size(), CV_16UC1);
  EXPECT_TRUE(boxesOfObjectsOnPlanes(
                  frame.depth, frame.intrinsics, segments,
                  computeSegmentStatistics(segments, frame.depth, frame.intrinsics), none)
                  .empty());
}

// The daemon's whole default chain (segmentation, statistics, planes, boxes) on frames of any
// size, down to one pixel, one row or one column: no crash, results inside the frame.
TEST(ObjectBoxes, WholeChainOnAnyFrameSize) {
  synthetic::SceneParams params;
  params.seed = 3;
  params.render_colour = false;
  const auto rendered = synthetic::SyntheticScene(params).render(0, 1);
  const Frame& frame = rendered.frame;
  HoughPlaneDetector planes_detector;
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(2, 3), cv::Size(3, 3), cv::Size(1, 480), cv::Size(640, 1),
        cv::Size(7, 5), cv::Size(33, 17), cv::Size(640, 480), cv::Size(101, 77)}) {
    const cv::Point at(std::min(180, frame.depth.cols - size.width),
                       std::min(140, frame.depth.rows - size.height));
    const cv::Mat depth = frame.depth(cv::Rect(at, size)).clone();
    CameraIntrinsics k = frame.intrinsics;
    k.cx -= at.x;
    k.cy -= at.y;
    k.width = size.width;
    k.height = size.height;
    for (const auto method : {SegmentationMethod::kDepthStep, SegmentationMethod::kFused}) {
      const cv::Mat segments = segmentDepth(depth, k, method);
      ASSERT_EQ(segments.size(), size);
      const auto statistics = computeSegmentStatistics(segments, depth, k);
      const auto planes = planes_detector.detect(depth, k);
      ASSERT_EQ(planes.labels.size(), size);
      for (const auto& box : boxesOfObjectsOnPlanes(depth, k, segments, statistics, planes))
        EXPECT_EQ(box.roi & cv::Rect(cv::Point(0, 0), size), box.roi) << size;
    }
  }
}

}  // namespace
}  // namespace shapesense
