// Least-squares plane fitting, polygon triangulation and the detector on analytic planes.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/planes/plane_polygon.h"
#include "shapesense/core/planes/plane_ransac.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {
namespace {

constexpr double kDeg = M_PI / 180.0;

TEST(PlaneFitting, ExactOnNoiselessPointsAndOrientedToTheViewpoint) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.9, -0.4).normalized();
  const double d = 1.3;
  PlaneMoments m;
  const Eigen::Vector3d a = n.unitOrthogonal(), b = n.cross(a);
  for (int i = -20; i <= 20; ++i)
    for (int j = -20; j <= 20; ++j) m.add(-d * n + 0.05 * i * a + 0.03 * j * b);
  const PlaneFit f = m.fit();
  ASSERT_TRUE(f.valid);
  EXPECT_NEAR(f.normal.dot(n), 1.0, 1e-12);
  EXPECT_NEAR(f.d, d, 1e-9);
  EXPECT_LT(f.rms_m, 1e-7);
  // Merged halves and a rigidly moved set give the same plane.
  PlaneMoments h1, h2;
  for (int i = -20; i <= 20; ++i) (i < 0 ? h1 : h2).add(-d * n + 0.05 * i * a + 0.01 * (i % 3) * b);
  PlaneMoments all = h1;
  all.merge(h2);
  PlaneMoments direct;
  for (int i = -20; i <= 20; ++i) direct.add(-d * n + 0.05 * i * a + 0.01 * (i % 3) * b);
  EXPECT_NEAR(all.fit().normal.dot(direct.fit().normal), 1.0, 1e-12);
  EXPECT_NEAR(all.fit().d, direct.fit().d, 1e-9);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.1, -0.2, 0.3);
  PlaneMoments moved = m;
  moved.transform(R, t);
  const PlaneFit g = moved.fit();
  EXPECT_NEAR(g.normal.dot(R * n), 1.0, 1e-9);
  EXPECT_NEAR(g.d, d - (R * n).dot(t), 1e-9);
}

TEST(PlaneFitting, ToleranceFollowsTheKinectNoise) {
  PlaneTolerance tol;
  EXPECT_NEAR(tol.at(1.0), 3 * 0.125 / 43.5, 1e-9);  // 8.6 mm
  EXPECT_NEAR(tol.at(3.0), 9 * 3 * 0.125 / 43.5, 1e-9);
  EXPECT_DOUBLE_EQ(tol.at(0.5), std::max(0.004, 0.25 * 3 * 0.125 / 43.5));
}

TEST(PlanePolygon, EarClippingTriangulatesConcavePolygons) {
  // An L shape (area 3), both orientations.
  std::vector<cv::Point2f> l = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  for (int pass = 0; pass < 2; ++pass) {
    const auto tris = triangulatePolygon(l);
    ASSERT_EQ(tris.size(), l.size() - 2);
    double area = 0;
    for (const auto& t : tris) {
      const auto &a = l[t[0]], &b = l[t[1]], &c = l[t[2]];
      const double s = 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
      EXPECT_GT(std::fabs(s), 0.0);
      area += std::fabs(s);
    }
    EXPECT_NEAR(area, 3.0, 1e-6);
    std::reverse(l.begin(), l.end());
  }
}

// Kinect-like rendering of analytic planes: disparity 43.5/z px with Gaussian noise of 0.5
// steps, quantised to 1/8 px.
cv::Mat renderPlanes(const std::vector<std::pair<Eigen::Vector3d, double>>& planes,
                     const CameraIntrinsics& K, std::vector<int>* owner = nullptr) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.5);
  cv::Mat depth(K.height, K.width, CV_16UC1, cv::Scalar(0));
  if (owner) owner->assign(K.width * K.height, -1);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      double best = 1e9;
      int who = -1;
      for (std::size_t p = 0; p < planes.size(); ++p) {
        const double den = planes[p].first.dot(K.ray(u, v));
        if (den >= -1e-9) continue;
        const double t = -planes[p].second / den;
        if (t > 0.5 && t < 4.5 && t < best) {
          best = t;
          who = static_cast<int>(p);
        }
      }
      if (who < 0) continue;
      const double disp = std::round(43.5 / best * 8.0 + noise(rng));
      depth.at<std::uint16_t>(v, u) =
          static_cast<std::uint16_t>(std::lround(43.5 / (disp / 8.0) * 1000.0));
      if (owner) (*owner)[v * K.width + u] = who;
    }
  return depth;
}

// Frames of any size, including a few pixels, one row or one column, give a label image of the
// frame's size and no crash (the sample grid may have no row or column); one detector object
// serves frames of alternating sizes, each with the result a fresh detector gives.
TEST(PlaneRefinement, AnySizeAndAlternatingSizesAndOtherSampleSteps) {
  const CameraIntrinsics K;
  const std::vector<std::pair<Eigen::Vector3d, double>> truth = {
      {Eigen::Vector3d(0, -1, -0.3).normalized(), 1.0},
      {Eigen::Vector3d(0.1, 0.1, -1).normalized(), 3.0},
  };
  const cv::Mat full = renderPlanes(truth, K, nullptr);
  const std::vector<cv::Size> sizes = {{1, 1},     {2, 3},     {3, 3},     {1, 480},
                                       {640, 1},   {5, 7},     {9, 2},     {17, 13},
                                       {640, 480}, {321, 241}, {640, 480}, {3, 3}};
  for (const int step : {1, 2, 3, 4, 6}) {
    HoughPlaneParams hp;
    hp.labeling.sample_step = step;
    hp.normals = HoughPlaneParams::defaultSampleNormalParams(step);
    HoughPlaneDetector reused(hp);
    RansacPlaneParams rp;
    rp.labeling.sample_step = step;
    for (const cv::Size& size : sizes) {
      if (step < 3 && size.area() == 640 * 480) continue;  // time: the small steps on crops only
      const cv::Mat depth = full(cv::Rect(0, 0, size.width, size.height)).clone();
      CameraIntrinsics crop = K;
      crop.width = size.width;
      crop.height = size.height;
      const PlaneDetection a = reused.detect(depth, crop);
      EXPECT_EQ(a.labels.size(), size) << "step " << step << " " << size;
      const PlaneDetection b = HoughPlaneDetector(hp).detect(depth, crop);
      ASSERT_EQ(a.planes.size(), b.planes.size()) << "step " << step << " " << size;
      for (std::size_t i = 0; i < a.planes.size(); ++i) {
        EXPECT_EQ(a.planes[i].normal, b.planes[i].normal);
        EXPECT_EQ(a.planes[i].d, b.planes[i].d);
        EXPECT_EQ(a.planes[i].inliers, b.planes[i].inliers);
      }
      EXPECT_EQ(cv::countNonZero(a.labels != b.labels), 0) << "step " << step << " " << size;
      const PlaneDetection r = detectPlanesRansac(depth, crop, {}, rp);
      EXPECT_EQ(r.labels.size(), size) << "ransac step " << step << " " << size;
    }
  }
}

TEST(PlaneRefinement, AnalyticPlanesRecoveredWithinNoise) {
  // A floor and a slanted wall meeting in a crease: each must come out as one region with
  // angle < 0.5 deg and distance < 5 mm, covering >= 95% of its pixels. (A plane crossing a far
  // wall at a shallow angle is harder: within the 3-step tolerance at 3 m (7.7 cm) the wall
  // takes a band of it, which biased d by 1.3-1.6 cm in a trial with a 27-deg ramp.)
  const CameraIntrinsics K;
  const std::vector<std::pair<Eigen::Vector3d, double>> truth = {
      {Eigen::Vector3d(0, -1, -0.3).normalized(), 1.0},
      {Eigen::Vector3d(0.1, 0.1, -1).normalized(), 3.0},
  };
  std::vector<int> owner;
  const cv::Mat depth = renderPlanes(truth, K, &owner);
  for (int method = 0; method < 2; ++method) {
    HoughPlaneDetector hough;
    const PlaneDetection out = method == 0 ? hough.detect(depth, K) : detectPlanesRansac(depth, K);
    for (std::size_t t = 0; t < truth.size(); ++t) {
      const DetectedPlane* best = nullptr;
      for (const auto& p : out.planes)
        if (p.normal.dot(truth[t].first) > std::cos(5 * kDeg) &&
            std::fabs(p.d - truth[t].second) < 0.05 && (!best || p.inliers > best->inliers))
          best = &p;
      ASSERT_NE(best, nullptr) << "method " << method << " plane " << t;
      EXPECT_LT(std::acos(std::min(1.0, best->normal.dot(truth[t].first))) / kDeg, 0.5)
          << method << " " << t;
      EXPECT_LT(std::fabs(best->d - truth[t].second), 0.005)
          << method << " " << t << " d " << best->d << " n " << best->normal.transpose();
      long own = 0, hit = 0;
      for (int i = 0; i < K.width * K.height; ++i) {
        if (owner[i] != static_cast<int>(t)) continue;
        ++own;
        hit += out.labels.at<std::uint16_t>(i / K.width, i % K.width) == best->id;
      }
      EXPECT_GE(static_cast<double>(hit) / own, 0.95)
          << method << " " << t << " regions " << out.planes.size();
    }
  }
}

}  // namespace
}  // namespace shapesense
