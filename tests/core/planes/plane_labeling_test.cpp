// Sample grids and full-resolution labelling (plane_labeling.h) on small analytic frames of every
// width from 1 to 41 pixels, so the vectorised loops meet runs that end at the row's end, runs
// shorter than their step and rows shorter than one step; the pixel kernels of every SIMD target
// against the scalar-equivalent one on those widths and on VGA frames.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "shapesense/core/planes/plane_labeling.h"
#include "simd_targets.h"

namespace shapesense {
namespace {

CameraIntrinsics smallCamera(int cols, int rows) {
  CameraIntrinsics K;
  K.fx = K.fy = 60.0;
  K.cx = 0.5 * (cols - 1);
  K.cy = 0.5 * (rows - 1);
  K.width = cols;
  K.height = rows;
  return K;
}

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(PlaneSampleGrid, PointsAreThoseOfTheScalarFormulaBitForBitOnEveryTarget) {
  testing::forEachSimdTarget([](const std::string& target) {
    for (int step = 1; step <= 5; ++step)
      for (int cols = 1; cols <= 41; cols += 4 + step) {
        const int rows = 9;
        cv::Mat depth(rows, cols, CV_16UC1);
        for (int v = 0; v < rows; ++v)
          for (int u = 0; u < cols; ++u)
            depth.at<std::uint16_t>(v, u) =
                (u * 7 + v * 3) % 5 == 0 ? 0 : static_cast<std::uint16_t>(600 + 37 * u + 11 * v);
        const CameraIntrinsics K = smallCamera(cols, rows);
        PlaneSampleGrid grid;
        grid.build(depth, K, step);
        ASSERT_EQ(grid.points.rows, (rows - grid.offset + step - 1) / step);
        ASSERT_EQ(grid.points.cols, (cols - grid.offset + step - 1) / step);
        const float ifx = static_cast<float>(1.0 / K.fx), ify = static_cast<float>(1.0 / K.fy);
        for (int r = 0; r < grid.points.rows; ++r)
          for (int c = 0; c < grid.points.cols; ++c) {
            const int u = grid.offset + c * step, v = grid.offset + r * step;
            const std::uint16_t d = depth.at<std::uint16_t>(v, u);
            ASSERT_EQ(grid.depth_mm.at<std::uint16_t>(r, c), d);
            const cv::Vec3f p = grid.points.at<cv::Vec3f>(r, c);
            if (d == 0) {
              EXPECT_TRUE(std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2]));
              continue;
            }
            const float z = static_cast<float>(d) * 0.001f;
            const float x = (static_cast<float>(u) - static_cast<float>(K.cx)) * ifx * z;
            const float y = (static_cast<float>(v) - static_cast<float>(K.cy)) * ify * z;
            EXPECT_TRUE(sameBits(p[0], x) && sameBits(p[1], y) && sameBits(p[2], z))
                << target << " step " << step << " cols " << cols << " sample " << r << "," << c;
          }
      }
  });
}

// Vertical stripes of 10 pixels, alternately on a tilted plane and on another 0.5 m behind it, in
// whole millimetres, with holes: the runs of candidates are short (single-candidate runs of a
// sample or two between two-candidate runs), and some end at the row's end. Every labelled
// pixel lies on the plane its region was grown from, every hole stays 0, and (almost) every valid
// pixel is labelled.
TEST(PlaneLabeling, EveryPixelTakesItsOwnPlaneAtAnyWidth) {
  const int rows = 14, stripe = 10;
  for (int cols = 1; cols <= 41; ++cols) {
    const CameraIntrinsics K = smallCamera(cols, rows);
    PlaneHypothesis near, far;
    near.normal = Eigen::Vector3d(0.25, -0.15, 1.0).normalized();
    near.d = -1.0;
    far.normal = Eigen::Vector3d(-0.1, 0.2, 1.0).normalized();
    far.d = -1.5;
    auto onNear = [&](int u) { return (u / stripe) % 2 == 0; };
    cv::Mat depth(rows, cols, CV_16UC1);
    for (int v = 0; v < rows; ++v)
      for (int u = 0; u < cols; ++u) {
        const PlaneHypothesis& h = onNear(u) ? near : far;
        const double z = -h.d / h.normal.dot(K.ray(u, v));
        const bool hole = (u * 5 + v * 3) % 11 == 0;
        depth.at<std::uint16_t>(v, u) = hole ? 0 : static_cast<std::uint16_t>(std::round(1e3 * z));
      }
    PlaneLabelingParams params;
    params.min_region_pixels = 1;
    params.compute_polygons = false;
    PlaneSampleGrid grid;
    grid.build(depth, K, params.sample_step);
    if (grid.points.empty()) continue;
    cv::Mat sample_labels(grid.points.size(), CV_32SC1);
    for (int r = 0; r < grid.points.rows; ++r)
      for (int c = 0; c < grid.points.cols; ++c) {
        const int u = grid.offset + c * grid.step;
        sample_labels.at<int>(r, c) =
            grid.depth_mm.at<std::uint16_t>(r, c) == 0 ? -1 : (onNear(u) ? 0 : 1);
      }
    const PlaneDetection out =
        labelPlanes(depth, K, cv::Mat(), grid, sample_labels, {near, far}, params);
    ASSERT_EQ(out.labels.size(), depth.size());
    auto sampleOf = [&](int x, int n) {  // the sample of pixel coordinate x (as the labelling)
      return std::clamp(
          static_cast<int>(std::lround(static_cast<double>(x - grid.offset) / grid.step)), 0,
          n - 1);
    };
    int valid = 0, labelled = 0;
    for (int v = 0; v < rows; ++v)
      for (int u = 0; u < cols; ++u) {
        const int l = out.labels.at<std::uint16_t>(v, u);
        const double z = 1e-3 * depth.at<std::uint16_t>(v, u);
        if (z == 0.0) {
          EXPECT_EQ(l, 0) << "cols " << cols << " hole " << u << "," << v;
          continue;
        }
        ++valid;
        // A pixel whose own sample is valid and on its stripe, a whole one, has its own plane
        // among its candidates: it is labelled.
        const int s = u / stripe, us = grid.offset + sampleOf(u, grid.points.cols) * grid.step,
                  vs = grid.offset + sampleOf(v, grid.points.rows) * grid.step;
        if ((s + 1) * stripe <= cols && us / stripe == s && depth.at<std::uint16_t>(vs, us) != 0) {
          EXPECT_NE(l, 0) << "cols " << cols << " pixel " << u << "," << v;
        }
        if (l == 0) continue;  // no candidate plane fits (next to a small or dropped region)
        ++labelled;
        ASSERT_LE(l, static_cast<int>(out.planes.size()));
        // The hypothesis of the pixel's region (its fit may rest on too few pixels to tell).
        const int group = out.planes[l - 1].group;
        ASSERT_TRUE(group == 0 || group == 1);
        const PlaneHypothesis& h = group == 0 ? near : far;
        EXPECT_LT(std::fabs(h.normal.dot(K.backproject(u, v, z)) + h.d), 0.005)
            << "cols " << cols << " pixel " << u << "," << v << " label " << l;
      }
    if (cols >= 20) {
      EXPECT_GE(labelled, valid * 9 / 10) << "cols " << cols;
    }
  }
}

// Blocks of bw x bh pixels on four planes that cross one another inside the frame (a few mm
// apart at 1 m, tilted differently), so that each corner of four blocks gives pixels four
// candidates and many pixels lie within the tolerance of several of them; whole-millimetre
// depths with +-2 mm of noise, holes, random colours. Sample labels: each valid sample's block
// plane, some left unlabelled (the growth takes them or not).
struct BlockFrame {
  cv::Mat depth, bgr, sample_labels;
  CameraIntrinsics K;
  PlaneSampleGrid grid;
  std::vector<PlaneHypothesis> planes;
};

BlockFrame blockFrame(int cols, int rows, double f, int bw, int bh, int step, unsigned seed) {
  BlockFrame fr;
  fr.K.fx = fr.K.fy = f;
  fr.K.cx = 0.5 * (cols - 1);
  fr.K.cy = 0.5 * (rows - 1);
  fr.K.width = cols;
  fr.K.height = rows;
  const double n[4][3] = {
      {0.05, 0.0, 1.0}, {-0.05, 0.02, 1.0}, {0.0, 0.06, 1.0}, {0.02, -0.04, 1.0}};
  const double d[4] = {-1.0, -1.004, -0.998, -1.006};
  for (int k = 0; k < 4; ++k) {
    PlaneHypothesis h;
    h.normal = Eigen::Vector3d(n[k][0], n[k][1], n[k][2]).normalized();
    h.d = d[k];
    fr.planes.push_back(h);
  }
  auto planeOf = [&](int u, int v) { return ((u / bw) + 2 * (v / bh)) % 4; };
  unsigned state = seed;
  auto next = [&state]() {
    state = state * 1664525u + 1013904223u;
    return state >> 8;
  };
  fr.depth.create(rows, cols, CV_16UC1);
  fr.bgr.create(rows, cols, CV_8UC3);
  for (int v = 0; v < rows; ++v)
    for (int u = 0; u < cols; ++u) {
      const PlaneHypothesis& h = fr.planes[planeOf(u, v)];
      const double z = -h.d / h.normal.dot(fr.K.ray(u, v));
      const int noise = static_cast<int>(next() % 5) - 2;
      const bool hole = next() % 13 == 0;
      fr.depth.at<std::uint16_t>(v, u) =
          hole ? 0 : static_cast<std::uint16_t>(std::lround(1e3 * z) + noise);
      const unsigned c = next();
      fr.bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(c & 255, (c >> 8) & 255, (c >> 16) & 255);
    }
  fr.grid.build(fr.depth, fr.K, step);
  fr.sample_labels.create(fr.grid.points.size(), CV_32SC1);
  for (int r = 0; r < fr.grid.points.rows; ++r)
    for (int c = 0; c < fr.grid.points.cols; ++c) {
      const int u = fr.grid.offset + c * step, v = fr.grid.offset + r * step;
      const bool valid = fr.grid.depth_mm.at<std::uint16_t>(r, c) != 0;
      fr.sample_labels.at<int>(r, c) = valid && next() % 17 != 0 ? planeOf(u, v) : -1;
    }
  return fr;
}

// Labels the frame with the kernels of every SIMD target (on a copy of its sample labels each):
// the same label image and the same planes, field for field, as the last target (the
// scalar-equivalent one).
void expectSameOnEveryTarget(const BlockFrame& fr, const PlaneLabelingParams& params,
                             const std::string& what) {
  std::vector<std::pair<std::string, PlaneDetection>> results;
  testing::forEachSimdTarget([&](const std::string& target) {
    cv::Mat sample_labels = fr.sample_labels.clone();
    results.emplace_back(
        target, labelPlanes(fr.depth, fr.K, fr.bgr, fr.grid, sample_labels, fr.planes, params));
  });
  ASSERT_FALSE(results.empty());
  const PlaneDetection& b = results.back().second;
  for (const auto& [target, a] : results) {
    const std::string where = what + " target " + target;
    ASSERT_EQ(a.labels.size(), fr.depth.size()) << where;
    ASSERT_EQ(a.labels.type(), CV_16UC1) << where;
    EXPECT_EQ(cv::countNonZero(a.labels != b.labels), 0) << where;
    ASSERT_EQ(a.planes.size(), b.planes.size()) << where;
    for (std::size_t k = 0; k < a.planes.size(); ++k) {
      const DetectedPlane &p = a.planes[k], &q = b.planes[k];
      EXPECT_EQ(p.id, q.id) << where << " plane " << k;
      EXPECT_EQ(p.group, q.group) << where << " plane " << k;
      EXPECT_EQ(p.normal, q.normal) << where << " plane " << k;
      EXPECT_EQ(p.d, q.d) << where << " plane " << k;
      EXPECT_EQ(p.inliers, q.inliers) << where << " plane " << k;
      EXPECT_EQ(p.rms_m, q.rms_m) << where << " plane " << k;
      EXPECT_EQ(p.box, q.box) << where << " plane " << k;
      EXPECT_EQ(p.polygon, q.polygon) << where << " plane " << k;
      EXPECT_EQ(p.triangles, q.triangles) << where << " plane " << k;
      EXPECT_EQ(p.mean_bgr, q.mean_bgr) << where << " plane " << k;
    }
  }
}

TEST(PlaneLabeling, EveryTargetGivesTheSameLabelsAtAnyWidth) {
  for (int step = 1; step <= 6; ++step)
    for (int cols = 1; cols <= 41; ++cols) {
      const BlockFrame fr = blockFrame(cols, 23, 60.0, 3 + cols % 7, 4 + step, step, 7u * cols);
      if (fr.grid.points.empty()) continue;
      PlaneLabelingParams params;
      params.sample_step = step;
      params.min_region_pixels = 1;
      expectSameOnEveryTarget(fr, params,
                              "step " + std::to_string(step) + " cols " + std::to_string(cols));
    }
}

TEST(PlaneLabeling, EveryTargetGivesTheSameLabelsOnVga) {
  for (int step = 1; step <= 6; ++step)
    for (const int block : {5, 37}) {
      const BlockFrame fr = blockFrame(640, 480, 570.0, block, block + 2, step, 11u * step + block);
      PlaneLabelingParams params;
      params.sample_step = step;
      params.min_region_pixels = block < 10 ? 10 : 300;
      expectSameOnEveryTarget(fr, params,
                              "step " + std::to_string(step) + " block " + std::to_string(block));
    }
}

// Labels are 16-bit (region index + 1). At step 1 the top rows of a VGA frame alternate between two
// planes pixel by pixel (every sample its own region: 70 400 of them, more than 65 535), and a
// third plane fills the rows below: its region comes after all of them. With the default minimum
// size the tiny regions are dropped and the large one is labelled; with a minimum of one pixel
// the regions past 65 535 are left unlabelled. Either way every plane's pixels carry its id, as
// many as its inliers.
TEST(PlaneLabeling, MoreRegionsThanSixteenBitLabelsHold) {
  const int cols = 640, rows = 480, top_rows = 110;
  CameraIntrinsics K;
  K.fx = K.fy = 570.0;
  K.cx = 319.5;
  K.cy = 239.5;
  K.width = cols;
  K.height = rows;
  std::vector<PlaneHypothesis> planes(3);
  for (int k = 0; k < 3; ++k) {
    planes[k].normal = Eigen::Vector3d(0.0, 0.0, 1.0);
    planes[k].d = -(1.0 + 0.2 * k);
  }
  auto planeOf = [&](int u, int v) { return v < top_rows ? (u + v) % 2 : 2; };
  cv::Mat depth(rows, cols, CV_16UC1);
  for (int v = 0; v < rows; ++v)
    for (int u = 0; u < cols; ++u)
      depth.at<std::uint16_t>(v, u) =
          static_cast<std::uint16_t>(std::lround(-1e3 * planes[planeOf(u, v)].d));
  for (const int min_pixels : {300, 1}) {
    PlaneLabelingParams params;
    params.sample_step = 1;
    params.min_region_pixels = min_pixels;
    params.compute_polygons = false;
    PlaneSampleGrid grid;
    grid.build(depth, K, 1);
    cv::Mat sample_labels(grid.points.size(), CV_32SC1);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) sample_labels.at<int>(r, c) = planeOf(c, r);
    const PlaneDetection out =
        labelPlanes(depth, K, cv::Mat(), grid, sample_labels, planes, params);
    ASSERT_EQ(out.labels.size(), depth.size());
    std::vector<std::size_t> pixels(out.planes.size() + 1, 0);
    for (int v = 0; v < rows; ++v)
      for (int u = 0; u < cols; ++u) {
        const int l = out.labels.at<std::uint16_t>(v, u);
        ASSERT_LE(l, static_cast<int>(out.planes.size())) << "min " << min_pixels;
        ++pixels[l];
      }
    for (const DetectedPlane& p : out.planes)
      EXPECT_EQ(pixels[p.id], p.inliers) << "min " << min_pixels << " plane " << p.id;
    const int bottom = out.labels.at<std::uint16_t>(rows - 1, cols / 2);
    if (min_pixels == 300) {
      // The large region is the one plane, and all of its pixels carry it.
      ASSERT_EQ(out.planes.size(), 1u);
      EXPECT_EQ(out.planes[0].group, 2);
      EXPECT_EQ(bottom, 1);
      EXPECT_EQ(out.planes[0].inliers, static_cast<std::size_t>(cols) * (rows - top_rows));
    } else {
      EXPECT_EQ(bottom, 0);  // region 70 400: past the 16-bit labels
    }
  }
}

}  // namespace
}  // namespace shapesense
