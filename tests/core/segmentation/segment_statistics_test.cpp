// Per-segment statistics on exact (unquantised) analytic depth.
#include "shapesense/core/segmentation/segment_statistics.h"

#include <cmath>
#include <filesystem>
#include <map>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/driver/tum_recording.h"
#include "test_paths.h"

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

// The statistics by the textbook two passes (mean, then covariance about it) over the
// back-projected pixels: a reference independent of the one-pass, run-wise sums under test.
struct Reference {
  SegmentStatistics stats;
  bool plane_well_defined = false;  // smallest covariance eigenvalue < 0.1x the middle one
};

std::map<int, Reference> twoPassReference(const cv::Mat& regions, const cv::Mat& depth,
                                          const CameraIntrinsics& K) {
  std::map<int, std::vector<Eigen::Vector3d>> points;
  std::map<int, cv::Rect> boxes;
  for (int v = 0; v < regions.rows; ++v)
    for (int u = 0; u < regions.cols; ++u) {
      const int id = regions.at<std::uint16_t>(v, u);
      const int mm = depth.at<std::uint16_t>(v, u);
      if (id == 0 || mm == 0) continue;
      points[id].push_back(K.backproject(u, v, mm * 1e-3));
      boxes[id] =
          points[id].size() == 1 ? cv::Rect(u, v, 1, 1) : (boxes[id] | cv::Rect(u, v, 1, 1));
    }
  std::map<int, Reference> out;
  for (const auto& [id, pts] : points) {
    Reference& ref = out[id];
    SegmentStatistics& s = ref.stats;
    s.id = static_cast<std::uint16_t>(id);
    s.pixels = static_cast<int>(pts.size());
    s.box = boxes[id];
    for (const auto& p : pts) s.centroid += p;
    s.centroid /= static_cast<double>(pts.size());
    if (pts.size() >= 3) {
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (const auto& p : pts) cov += (p - s.centroid) * (p - s.centroid).transpose();
      cov /= static_cast<double>(pts.size());
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
      s.mean_normal = es.eigenvectors().col(0);
      if (s.mean_normal.dot(s.centroid) > 0) s.mean_normal = -s.mean_normal;
      s.plane_rms_m = std::sqrt(std::max(0.0, es.eigenvalues()(0)));
      ref.plane_well_defined = es.eigenvalues()(0) < 0.1 * es.eigenvalues()(1);
    }
  }
  return out;
}

// Real frames (holes, noise, ~60 regions of every size from the depth-step segmentation of
// one frame of each of four recordings): every statistic matches the two-pass reference.
// Tolerances: 1e-9 m on the centroid and the rms (the two differ only in rounding), 1e-6 on the
// normal for regions whose plane is well defined (smallest eigenvalue at least 10x below the next;
// otherwise the normal is an ill-conditioned eigenvector and rounding may turn it).
TEST(SegmentStatistics, RealFramesMatchTwoPassReference) {
  int compared = 0;
  for (const char* name : {"pcl_office", "tum_fr2_desk", "pcl_room_sweep", "mosd_tabletop"}) {
    const auto dir = testing::realRecording(name);
    if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " missing";
    const TumIndex index = readTumIndex(dir);
    ASSERT_FALSE(index.depth.empty());
    const std::size_t f = 0;
    const cv::Mat raw =
        cv::imread((dir / index.depth[f].relative_path).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(raw.empty());
    cv::Mat mm;
    raw.convertTo(mm, CV_16UC1, 1000.0 / index.camera.depth_scale);
    const CameraIntrinsics& K = index.camera.intrinsics;
    cv::Mat regions = segmentDepth(mm, K, SegmentationMethod::kDepthStep);
    // Regions that also cover pixels without depth, so runs have holes in them.
    regions(cv::Rect(0, 0, 40, 30)).setTo(65535);
    const auto stats = computeSegmentStatistics(regions, mm, K);
    const auto ref = twoPassReference(regions, mm, K);
    ASSERT_EQ(stats.size(), ref.size()) << name;
    for (const auto& s : stats) {
      SCOPED_TRACE(std::string(name) + " region " + std::to_string(s.id));
      ASSERT_TRUE(ref.count(s.id));
      const SegmentStatistics& r = ref.at(s.id).stats;
      EXPECT_EQ(s.pixels, r.pixels);
      EXPECT_EQ(s.box, r.box);
      EXPECT_LT((s.centroid - r.centroid).norm(), 1e-9);
      EXPECT_NEAR(s.plane_rms_m, r.plane_rms_m, 1e-9);
      if (ref.at(s.id).plane_well_defined) {
        EXPECT_LT((s.mean_normal - r.mean_normal).norm(), 1e-6);
        ++compared;
      }
    }
  }
  EXPECT_GE(compared, 10);  // the normal check is not vacuous (14 regions when written)
}

}  // namespace
}  // namespace shapesense
