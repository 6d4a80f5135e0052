// Per-segment statistics on exact (unquantised) analytic depth.
#include "shapesense/core/segment_statistics.h"

#include <cmath>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

TEST(SegmentStatistics, PlaneAndFrontoSquare) {
  const CameraIntrinsics K;
  cv::Mat depth(K.height, K.width, CV_16UC1), regions(K.height, K.width, CV_16UC1, cv::Scalar(0));
  // Region 3: floor y = 0.5 m (normal (0,-1,0)) seen in rows 300..479; region 9: a fronto square
  // at exactly 1.2 m in rows 50..149, cols 100..299. Everything else has no depth.
  depth.setTo(0);
  for (int v = 300; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const double z = 0.5 * K.fy / (v - K.cy);
      depth.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::lround(z * 1000));
      regions.at<std::uint16_t>(v, u) = 3;
    }
  depth(cv::Rect(100, 50, 200, 100)).setTo(1200);
  regions(cv::Rect(100, 50, 200, 100)).setTo(9);
  regions.at<std::uint16_t>(0, 0) = 5;  // a region without depth is omitted

  const auto stats = computeSegmentStatistics(regions, depth, K);
  ASSERT_EQ(stats.size(), 2u);
  EXPECT_EQ(stats[0].id, 3);
  EXPECT_EQ(stats[0].pixels, 180 * 640);
  EXPECT_EQ(stats[0].box, cv::Rect(0, 300, 640, 180));
  EXPECT_NEAR(stats[0].mean_normal.y(), -1.0, 1e-3);
  EXPECT_NEAR(stats[0].centroid.y(), 0.5, 2e-3);  // mm rounding of depth
  EXPECT_LT(stats[0].plane_rms_m, 1e-3);

  EXPECT_EQ(stats[1].id, 9);
  EXPECT_EQ(stats[1].pixels, 200 * 100);
  EXPECT_EQ(stats[1].box, cv::Rect(100, 50, 200, 100));
  EXPECT_NEAR(stats[1].centroid.z(), 1.2, 1e-9);
  EXPECT_NEAR(stats[1].centroid.x(), (199.5 - K.cx) * 1.2 / K.fx, 1e-9);
  EXPECT_NEAR(stats[1].centroid.y(), (99.5 - K.cy) * 1.2 / K.fy, 1e-9);
  EXPECT_NEAR(stats[1].mean_normal.z(), -1.0, 1e-9);
  EXPECT_NEAR(stats[1].plane_rms_m, 0.0, 1e-9);
}

}  // namespace
}  // namespace shapesense
