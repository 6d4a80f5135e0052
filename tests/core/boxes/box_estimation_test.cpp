// Geometry, robustness and error cases of estimateBox on analytic depth images.

#include "shapesense/core/boxes/box_estimation.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <variant>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace shapesense {
namespace {

constexpr double kTightM = 1e-9;  // pure arithmetic on the same inputs
// Mode 1's ranges are counted in 1 mm bins (rounded by <= 0.5 mm each); their mean and std
// are then off by far less than that.
constexpr double kBinnedRangeM = 0.5e-3;

cv::Mat wall(double z_m, int width = 640, int height = 480) {
  return cv::Mat(height, width, CV_16UC1, cv::Scalar(std::round(z_m * 1000.0)));
}

// Paints depth z(u, v) (metres) into the inclusive pixel rectangle [u0, u1] x [v0, v1].
void paint(cv::Mat& depth, int u0, int v0, int u1, int v1,
           const std::function<double(int, int)>& z) {
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      depth.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::lround(z(u, v) * 1000.0));
    }
  }
}

struct Moments {
  double mean = 0.0;
  double stddev = 0.0;
};

// Mean / population std of Z (or of the distance from the origin) over the ROI's readings,
// computed independently of the implementation.
Moments roiMoments(const cv::Mat& depth, const CameraIntrinsics& k, int u0, int v0, int u1, int v1,
                   bool range) {
  std::vector<double> vals;
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const auto d = depth.at<std::uint16_t>(v, u);
      if (d == 0) continue;
      const double z = d * 0.001;
      vals.push_back(range ? z * std::sqrt(std::pow((u - k.cx) / k.fx, 2) +
                                           std::pow((v - k.cy) / k.fy, 2) + 1.0)
                           : z);
    }
  }
  Moments m;
  for (double x : vals) m.mean += x;
  m.mean /= static_cast<double>(vals.size());
  for (double x : vals) m.stddev += (x - m.mean) * (x - m.mean);
  m.stddev = std::sqrt(m.stddev / static_cast<double>(vals.size()));
  return m;
}

BoxEstimate expectBox(const std::variant<BoxEstimate, BoxEstimationFailure>& result) {
  if (const auto* failure = std::get_if<BoxEstimationFailure>(&result)) {
    ADD_FAILURE() << "estimateBox failed: " << toString(failure->code) << ": " << failure->message;
    return {};
  }
  return std::get<BoxEstimate>(result);
}

BoxEstimationError expectError(const std::variant<BoxEstimate, BoxEstimationFailure>& result) {
  if (!std::holds_alternative<BoxEstimationFailure>(result)) {
    ADD_FAILURE() << "expected an error, got a box";
    return BoxEstimationError::kInvalidArgument;
  }
  const auto& failure = std::get<BoxEstimationFailure>(result);
  EXPECT_FALSE(failure.message.empty());
  return failure.code;
}

// ROI outer edges in pixels (the frustum passes through the border pixels' outer edges).
struct RoiEdges {
  double left, right, top, bottom;
};
RoiEdges edges(int u0, int v0, int u1, int v1) { return {u0 - 0.5, u1 + 0.5, v0 - 0.5, v1 + 0.5}; }

// A plane tilted in depth across the ROI: z from z0 at u0 to z0 + dz at u1.
std::function<double(int, int)> tiltedX(int u0, int u1, double z0, double dz) {
  return [=](int u, int) { return z0 + dz * (u - u0) / double(u1 - u0); };
}

// ---------------------------------------------------------------------------------------------
// Mode 3: front face projects onto the ROI; faces at mean -/+ k * std of Z.

TEST(BoxEstimationMode3, CleanTiltedPlaneFacesAtMeanMinusPlusStdAndFrontProjectsOntoRoi) {
  const CameraIntrinsics k;
  const int u0 = 400, v0 = 100, u1 = 520, v1 = 180;  // off-centre on purpose
  cv::Mat depth = wall(2.5);
  paint(depth, u0, v0, u1, v1, tiltedX(u0, u1, 1.2, 0.1));
  BoxEstimationParams params;
  params.std_scale = 1.0;  // the seed's choice, so the expectation is literally mean -/+ std

  const auto box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kAxisAlignedFrontFace, params));
  const Moments m = roiMoments(depth, k, u0, v0, u1, v1, false);
  EXPECT_EQ(box.stats.valid_pixels, (u1 - u0 + 1) * (v1 - v0 + 1));
  EXPECT_EQ(box.stats.used_pixels, box.stats.valid_pixels);  // an even spread is all inliers
  EXPECT_NEAR(box.stats.mean_m, m.mean, kTightM);
  EXPECT_NEAR(box.stats.std_m, m.stddev, kTightM);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(box.corners[i].z(), m.mean - m.stddev, kTightM) << "front corner " << i;
    EXPECT_NEAR(box.corners[i + 4].z(), m.mean + m.stddev, kTightM) << "back corner " << i;
    // Axis aligned: the back face is the front face pushed along z.
    EXPECT_NEAR(box.corners[i + 4].x(), box.corners[i].x(), kTightM);
    EXPECT_NEAR(box.corners[i + 4].y(), box.corners[i].y(), kTightM);
  }
  // Front corners project onto the ROI's corners: within 0.5 px of the corner pixel centres
  // (exactly onto their outer edges, the ROI's footprint).
  const RoiEdges e = edges(u0, v0, u1, v1);
  const std::array<Eigen::Vector2d, 4> expected{
      Eigen::Vector2d(e.left, e.top), Eigen::Vector2d(e.right, e.top),
      Eigen::Vector2d(e.right, e.bottom), Eigen::Vector2d(e.left, e.bottom)};
  const std::array<Eigen::Vector2d, 4> pixel{Eigen::Vector2d(u0, v0), Eigen::Vector2d(u1, v0),
                                             Eigen::Vector2d(u1, v1), Eigen::Vector2d(u0, v1)};
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d p = k.project(box.corners[i]);
    EXPECT_LT((p - expected[i]).norm(), 1e-6) << "front corner " << i;
    EXPECT_LE((p - pixel[i]).cwiseAbs().maxCoeff(), 0.5 + 1e-6) << "front corner " << i;
  }
  EXPECT_FALSE(box.collapsed_x);
  EXPECT_FALSE(box.collapsed_y);
  EXPECT_EQ(box.stats.moved_back_m, 0.0);
  EXPECT_FALSE(box.stats.range_from_origin);
}

TEST(BoxEstimationMode3, DefaultsReachTheEndsOfAnEvenSpreadButNotBeyond) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(2.5);
  paint(depth, 300, 200, 360, 260, tiltedX(300, 360, 1.0, 0.2));
  const BoxEstimationParams params;  // defaults
  const auto box = expectBox(
      estimateBox(depth, k, {300, 200}, {360, 260}, BoxMode::kAxisAlignedFrontFace, params));
  // An even 1.0 - 1.2 m spread: the seed's mean -/+ std would stop ~4 cm short of each end.
  // The widened faces are clamped to the 1st / 99th percentile of the readings: within 3 mm
  // of the ends (1 % of 0.2 m = 2 mm, plus mm rounding), never beyond them.
  EXPECT_NEAR(box.corners[0].z(), 1.0, 0.003);
  EXPECT_NEAR(box.corners[4].z(), 1.2, 0.003);
  EXPECT_GE(box.corners[0].z(), 1.0);
  EXPECT_LE(box.corners[4].z(), 1.2);
  // Without the clamp the faces are literally mean -/+ std_scale * std.
  BoxEstimationParams unclamped;
  unclamped.clamp_to_kept_range = false;
  const auto wide = expectBox(
      estimateBox(depth, k, {300, 200}, {360, 260}, BoxMode::kAxisAlignedFrontFace, unclamped));
  EXPECT_NEAR(wide.corners[0].z(), wide.stats.mean_m - unclamped.std_scale * wide.stats.std_m,
              kTightM);
  EXPECT_NEAR(wide.corners[4].z(), wide.stats.mean_m + unclamped.std_scale * wide.stats.std_m,
              kTightM);
}

TEST(BoxEstimationMode3, OneByOneRoiIsAValidNonDegenerateBox) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(1.5);
  const auto box =
      expectBox(estimateBox(depth, k, {100, 50}, {100, 50}, BoxMode::kAxisAlignedFrontFace));
  // One pixel at 1.5 m spans 1.5 / 525 m.
  EXPECT_NEAR(box.corners[1].x() - box.corners[0].x(), 1.5 / 525.0, 1e-9);
  EXPECT_NEAR(box.corners[3].y() - box.corners[0].y(), 1.5 / 525.0, 1e-9);
  EXPECT_EQ(box.stats.valid_pixels, 1);
}

TEST(BoxEstimation, CornerArgumentOrderDoesNotMatter) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(2.5);
  paint(depth, 200, 150, 260, 230, tiltedX(200, 260, 1.1, 0.15));
  for (BoxMode mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    const auto a = expectBox(estimateBox(depth, k, {200, 150}, {260, 230}, mode));
    const auto b = expectBox(estimateBox(depth, k, {260, 150}, {200, 230}, mode));
    const auto c = expectBox(estimateBox(depth, k, {260, 230}, {200, 150}, mode));
    for (int i = 0; i < 8; ++i) {
      EXPECT_LT((a.corners[i] - b.corners[i]).norm(), kTightM) << toString(mode);
      EXPECT_LT((a.corners[i] - c.corners[i]).norm(), kTightM) << toString(mode);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Mode 1: oriented to the frustum.

TEST(BoxEstimationMode1, CornersOnFrustumEdgesFrontFacePerpendicularToCentralAxis) {
  const CameraIntrinsics k;
  const int u0 = 420, v0 = 60, u1 = 560, v1 = 150;  // far off-centre: the box is visibly turned
  cv::Mat depth = wall(2.5);
  paint(depth, u0, v0, u1, v1, tiltedX(u0, u1, 1.3, 0.12));
  BoxEstimationParams params;
  params.std_scale = 1.0;
  const auto box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kFrustumAligned, params));
  EXPECT_TRUE(box.stats.range_from_origin);

  // Distances from the origin, not Z: mean / std of the ranges.
  const Moments m = roiMoments(depth, k, u0, v0, u1, v1, true);
  EXPECT_NEAR(box.stats.mean_m, m.mean, kBinnedRangeM);
  EXPECT_NEAR(box.stats.std_m, m.stddev, kBinnedRangeM);

  const RoiEdges e = edges(u0, v0, u1, v1);
  const std::array<Eigen::Vector3d, 4> rays{k.ray(e.left, e.top), k.ray(e.right, e.top),
                                            k.ray(e.right, e.bottom), k.ray(e.left, e.bottom)};
  const Eigen::Vector3d axis =
      k.ray(0.5 * (e.left + e.right), 0.5 * (e.top + e.bottom)).normalized();
  for (int i = 0; i < 4; ++i) {
    // On the edge ray: parallel to it and in front of the camera.
    const Eigen::Vector3d dir = box.corners[i].normalized();
    EXPECT_LT(dir.cross(rays[i].normalized()).norm(), 1e-9) << "front corner " << i;
    EXPECT_GT(box.corners[i].z(), 0.0);
    // Front face in the plane perpendicular to the axis through the axis point at mean - std.
    EXPECT_NEAR(axis.dot(box.corners[i]), box.stats.mean_m - box.stats.std_m, 1e-9)
        << "front corner " << i;
    // Back face: the front face pushed along the axis to the axis point at mean + std.
    const Eigen::Vector3d push = box.corners[i + 4] - box.corners[i];
    EXPECT_LT(push.normalized().cross(axis).norm(), 1e-9) << "corner " << i;
    EXPECT_NEAR(push.norm(), 2.0 * box.stats.std_m, 1e-9) << "corner " << i;
    EXPECT_GT(push.dot(axis), 0.0);
  }
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      EXPECT_NEAR((box.corners[i] - box.corners[j]).normalized().dot(axis), 0.0, 1e-9);
    }
  }
  // Turned: not axis aligned (front corners at different z).
  EXPECT_GT(std::abs(box.corners[0].z() - box.corners[2].z()), 0.01);
  // The front face projects onto the ROI.
  const Eigen::Vector2d p0 = k.project(box.corners[0]);
  const Eigen::Vector2d p2 = k.project(box.corners[2]);
  EXPECT_NEAR(p0.x(), e.left, 1e-6);
  EXPECT_NEAR(p0.y(), e.top, 1e-6);
  EXPECT_NEAR(p2.x(), e.right, 1e-6);
  EXPECT_NEAR(p2.y(), e.bottom, 1e-6);
}

TEST(BoxEstimationMode1, CentredRoiGivesAnAxisAlignedRectangularBox) {
  const CameraIntrinsics k;
  // Symmetric about the principal point (319.5, 239.5).
  cv::Mat depth = wall(1.0);
  paint(depth, 290, 210, 349, 269, [](int, int) { return 1.0; });
  const auto box = expectBox(estimateBox(depth, k, {290, 210}, {349, 269}));
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(box.corners[i].z(), box.corners[i < 4 ? 0 : 4].z(), 1e-9);
  }
  const double w = box.corners[1].x() - box.corners[0].x();
  const double h = box.corners[3].y() - box.corners[0].y();
  const double d = box.corners[4].z() - box.corners[0].z();
  EXPECT_NEAR(boxVolume(box.corners), w * h * d, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Mode 2: the whole box projects into the ROI.

void expectProjectionInsideRoiAndTouching(const BoxEstimate& box, const CameraIntrinsics& k,
                                          const RoiEdges& e) {
  double min_u = 1e9, max_u = -1e9, min_v = 1e9, max_v = -1e9;
  for (const auto& c : box.corners) {
    const Eigen::Vector2d p = k.project(c);
    min_u = std::min(min_u, p.x());
    max_u = std::max(max_u, p.x());
    min_v = std::min(min_v, p.y());
    max_v = std::max(max_v, p.y());
  }
  // Inside (1e-6 px slack for rounding) and as wide as allowed: each ROI edge is touched.
  EXPECT_GE(min_u, e.left - 1e-6);
  EXPECT_LE(max_u, e.right + 1e-6);
  EXPECT_GE(min_v, e.top - 1e-6);
  EXPECT_LE(max_v, e.bottom + 1e-6);
  EXPECT_NEAR(min_u, e.left, 1e-6);
  EXPECT_NEAR(max_u, e.right, 1e-6);
  EXPECT_NEAR(min_v, e.top, 1e-6);
  EXPECT_NEAR(max_v, e.bottom, 1e-6);
}

TEST(BoxEstimationMode2, OffCentreBoxProjectsInsideRoiWithFacesAtMeanMinusPlusStd) {
  const CameraIntrinsics k;
  const int u0 = 450, v0 = 300, u1 = 540, v1 = 400;  // right of and below the principal point
  cv::Mat depth = wall(2.5);
  paint(depth, u0, v0, u1, v1, tiltedX(u0, u1, 1.0, 0.2));
  BoxEstimationParams params;
  params.std_scale = 1.0;
  const auto box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kAxisAlignedContained, params));
  const Moments m = roiMoments(depth, k, u0, v0, u1, v1, false);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(box.corners[i].z(), m.mean - m.stddev, kTightM);
    EXPECT_NEAR(box.corners[i + 4].z(), m.mean + m.stddev, kTightM);
  }
  const RoiEdges e = edges(u0, v0, u1, v1);
  expectProjectionInsideRoiAndTouching(box, k, e);
  // Off-centre: the left/top box edges come from the back face (seed's T1 on t1 at the far
  // depth), the right/bottom ones from the front face (T2 on t2 at the near depth).
  const double near = m.mean - m.stddev, far = m.mean + m.stddev;
  EXPECT_NEAR(box.corners[0].x(), (e.left - k.cx) / k.fx * far, kTightM);
  EXPECT_NEAR(box.corners[1].x(), (e.right - k.cx) / k.fx * near, kTightM);
  EXPECT_NEAR(box.corners[0].y(), (e.top - k.cy) / k.fy * far, kTightM);
  EXPECT_NEAR(box.corners[2].y(), (e.bottom - k.cy) / k.fy * near, kTightM);
  EXPECT_FALSE(box.collapsed_x);
  EXPECT_FALSE(box.collapsed_y);
}

TEST(BoxEstimationMode2, RoiStraddlingThePrincipalPointIsBoundByTheFrontFace) {
  const CameraIntrinsics k;
  const int u0 = 250, v0 = 180, u1 = 400, v1 = 300;
  cv::Mat depth = wall(2.5);
  paint(depth, u0, v0, u1, v1, tiltedX(u0, u1, 1.0, 0.3));
  const auto box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kAxisAlignedContained));
  const RoiEdges e = edges(u0, v0, u1, v1);
  expectProjectionInsideRoiAndTouching(box, k, e);
  // Same as mode 3 here (the seed: "the calculation is identical to mode #3").
  const auto box3 =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kAxisAlignedFrontFace));
  for (int i = 0; i < 8; ++i) EXPECT_LT((box.corners[i] - box3.corners[i]).norm(), kTightM);
}

TEST(BoxEstimationMode2, DeepBoxInNarrowOffCentreRoiCollapsesToMeanX) {
  const CameraIntrinsics k;
  // 6 px wide, far right; depth spread 1 - 2 m down the rows: no 1 m deep box fits in x.
  const int u0 = 600, v0 = 200, u1 = 605, v1 = 280;
  cv::Mat depth = wall(3.0);
  paint(depth, u0, v0, u1, v1, [](int, int v) { return 1.0 + (v - 200) / 80.0; });
  const auto box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kAxisAlignedContained));
  ASSERT_TRUE(box.collapsed_x);
  EXPECT_FALSE(box.collapsed_y);  // the rows straddle the principal point
  const RoiEdges e = edges(u0, v0, u1, v1);
  const double near = box.stats.near_m, far = box.stats.far_m;
  const double t1 = (e.left - k.cx) / k.fx * far;    // left bound from the back face
  const double t2 = (e.right - k.cx) / k.fx * near;  // right bound from the front face
  ASSERT_GT(t1, t2);                                 // the bounds cross: degenerate
  for (const auto& c : box.corners) EXPECT_NEAR(c.x(), 0.5 * (t1 + t2), kTightM);
  EXPECT_NEAR(boxVolume(box.corners), 0.0, 1e-12);
  // Depths are kept (the seed only collapses the coordinate).
  EXPECT_NEAR(box.corners[0].z(), box.stats.near_m, kTightM);
  EXPECT_NEAR(box.corners[4].z(), box.stats.far_m, kTightM);
  EXPECT_LT(box.stats.near_m, 1.05);
  EXPECT_GT(box.stats.far_m, 1.95);
}

TEST(BoxEstimationMode2, DeepBoxInShortRoiAboveCentreCollapsesY) {
  const CameraIntrinsics k;
  const int u0 = 300, v0 = 20, u1 = 340, v1 = 24;  // 5 rows near the top, columns straddle
  cv::Mat depth = wall(3.0);
  paint(depth, u0, v0, u1, v1, [](int u, int) { return 1.0 + (u - 300) / 40.0; });
  const auto box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, BoxMode::kAxisAlignedContained));
  ASSERT_TRUE(box.collapsed_y);
  EXPECT_FALSE(box.collapsed_x);
  const RoiEdges e = edges(u0, v0, u1, v1);
  const double t1 = (e.top - k.cy) / k.fy * box.stats.near_m;    // top bound: front face
  const double t2 = (e.bottom - k.cy) / k.fy * box.stats.far_m;  // bottom bound: back face
  for (const auto& c : box.corners) EXPECT_NEAR(c.y(), 0.5 * (t1 + t2), kTightM);
}

// ---------------------------------------------------------------------------------------------
// The near-limit ("focal plane") rule.

class BoxEstimationMoveBack : public ::testing::TestWithParam<BoxMode> {};

TEST_P(BoxEstimationMoveBack, FrontCornerNeverCloserThanTheNearLimitAndDepthExtentKept) {
  const CameraIntrinsics k;
  const int u0 = 380, v0 = 260, u1 = 470, v1 = 330;
  cv::Mat depth = wall(2.5);
  paint(depth, u0, v0, u1, v1, tiltedX(u0, u1, 1.2, 0.1));
  BoxEstimationParams free_params;
  free_params.min_front_depth_m = 0.0;
  const auto free_box =
      expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, GetParam(), free_params));
  BoxEstimationParams params;
  params.min_front_depth_m = 1.4;  // behind the object's near face: the rule must kick in
  const auto box = expectBox(estimateBox(depth, k, {u0, v0}, {u1, v1}, GetParam(), params));

  double min_front_z = 1e9;
  for (int i = 0; i < 4; ++i) min_front_z = std::min(min_front_z, box.corners[i].z());
  EXPECT_NEAR(min_front_z, 1.4, 1e-9);
  EXPECT_GT(box.stats.moved_back_m, 0.0);
  EXPECT_NEAR(box.stats.far_m - box.stats.near_m, free_box.stats.far_m - free_box.stats.near_m,
              1e-9);
  EXPECT_NEAR(box.stats.near_m - free_box.stats.near_m, box.stats.moved_back_m, 1e-9);
  const RoiEdges e = edges(u0, v0, u1, v1);
  if (GetParam() == BoxMode::kAxisAlignedContained) {
    expectProjectionInsideRoiAndTouching(box, k, e);
  } else {
    // Modes 1 and 3 keep their front face on the ROI's frustum.
    EXPECT_NEAR(k.project(box.corners[0]).x(), e.left, 1e-6);
    EXPECT_NEAR(k.project(box.corners[2]).y(), e.bottom, 1e-6);
  }
  EXPECT_EQ(free_box.stats.moved_back_m, 0.0);
}

INSTANTIATE_TEST_SUITE_P(AllModes, BoxEstimationMoveBack,
                         ::testing::Values(BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained,
                                           BoxMode::kAxisAlignedFrontFace),
                         [](const auto& info) { return std::string(toString(info.param)); });

TEST(BoxEstimation, HugeSpreadNeverPutsTheBoxBehindTheCamera) {
  // Half the ROI at 0.5 m, half at 8 m: mean - std < 0. The defaults keep it at >= 0.4 m.
  const CameraIntrinsics k;
  cv::Mat depth = wall(8.0);
  paint(depth, 100, 100, 149, 199, [](int, int) { return 0.5; });
  BoxEstimationParams params;
  params.inlier_sigmas = 100.0;  // defeat the robust window on purpose
  for (BoxMode mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    const auto box = expectBox(estimateBox(depth, k, {100, 100}, {199, 199}, mode, params));
    for (const auto& c : box.corners) EXPECT_GE(c.z(), 0.4 - 1e-9) << toString(mode);
  }
}

// ---------------------------------------------------------------------------------------------
// Robustness: background in the ROI moves the box little.

TEST(BoxEstimationRobustness, TenPercentWallPixelsBarelyMoveTheBox) {
  const CameraIntrinsics k;
  const int u0 = 260, v0 = 200, u1 = 379, v1 = 279;
  cv::RNG rng(12345);
  cv::Mat clean = wall(2.5);
  // Noisy tilted face: 1.2 - 1.3 m, 4 mm Gaussian noise.
  paint(clean, u0, v0, u1, v1,
        [&](int u, int) { return 1.2 + 0.1 * (u - u0) / double(u1 - u0) + rng.gaussian(0.004); });
  // Same object, but 10 % of its pixels (random) see the wall through it, plus a 4 px band of
  // wall around it inside a slightly larger ROI: ~17 % background in all.
  cv::Mat dirty = clean.clone();
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      if (rng.uniform(0.0, 1.0) < 0.10) dirty.at<std::uint16_t>(v, u) = 2500;
    }
  }
  for (BoxMode mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    const auto ref = expectBox(estimateBox(clean, k, {u0, v0}, {u1, v1}, mode));
    const auto got = expectBox(estimateBox(dirty, k, {u0 - 4, v0 - 4}, {u1 + 4, v1 + 4}, mode));
    EXPECT_LT(got.stats.used_pixels, got.stats.valid_pixels);
    // Near / far within 5 mm (the wall is 1.2 m behind: the seed's plain statistics would put
    // the back face ~0.9 m further), volume within the ROI growth plus 10 %.
    EXPECT_NEAR(got.stats.near_m, ref.stats.near_m, 0.005) << toString(mode);
    EXPECT_NEAR(got.stats.far_m, ref.stats.far_m, 0.005) << toString(mode);
    const double area_growth = (124.0 * 88.0) / (120.0 * 80.0);
    EXPECT_LT(boxVolume(got.corners), boxVolume(ref.corners) * area_growth * 1.10)
        << toString(mode);
    // Plain mean/std over all readings, for contrast (documents why the window exists).
    BoxEstimationParams plain;
    plain.inlier_sigmas = 1e6;
    const auto naive =
        expectBox(estimateBox(dirty, k, {u0 - 4, v0 - 4}, {u1 + 4, v1 + 4}, mode, plain));
    EXPECT_GT(naive.stats.far_m - got.stats.far_m, 0.3) << toString(mode);
  }
}

TEST(BoxEstimationRobustness, FlatFaceWithQuantisedDepthKeepsItsPixels) {
  // Every pixel reads exactly 1.500 m: MAD = 0, the sigma floor keeps the window open.
  const CameraIntrinsics k;
  cv::Mat depth = wall(3.0);
  paint(depth, 200, 200, 260, 260, [](int, int) { return 1.5; });
  const auto box =
      expectBox(estimateBox(depth, k, {195, 195}, {265, 265}, BoxMode::kAxisAlignedFrontFace));
  EXPECT_EQ(box.stats.used_pixels, 61 * 61);
  EXPECT_NEAR(box.corners[0].z(), 1.5, 1e-9);
  EXPECT_NEAR(box.corners[4].z(), 1.5, 1e-9);
}

TEST(BoxEstimationRobustness, StatisticOnSamples) {
  // 80 % object evenly over 1.00 - 1.10 m, 20 % wall at 2.5 m.
  std::vector<double> values;
  for (int i = 0; i < 800; ++i) values.push_back(1.0 + 0.1 * i / 799.0);
  for (int i = 0; i < 200; ++i) values.push_back(2.5);
  const RoiDepthStatistics s = robustDepthStatistics(values);
  EXPECT_EQ(s.valid_pixels, 1000);
  EXPECT_EQ(s.used_pixels, 800);
  // Values off the millimetre grid: the statistic counts them in 1 mm bins.
  EXPECT_NEAR(s.mean_m, 1.05, 0.0005);
  EXPECT_NEAR(s.min_m, 1.0, 1e-12);
  EXPECT_NEAR(s.max_m, 1.1, 1e-12);
  EXPECT_NEAR(s.std_m, 0.1 / std::sqrt(12.0), 1e-4);
  // Faces: mean -/+ 2.5 std would pass both ends; clamped to the 1st / 99th percentiles of
  // the 800 kept values (ranks floor(0.01 * 799) = 7 and ceil(0.99 * 799) = 792), which the
  // statistic reads from its 1 mm bins: within half a bin of the values.
  EXPECT_NEAR(s.near_m, 1.0 + 0.1 * 7 / 799.0, 0.0005 + 1e-12);
  EXPECT_NEAR(s.far_m, 1.0 + 0.1 * 792 / 799.0, 0.0005 + 1e-12);
}

TEST(BoxEstimationRobustness, StatisticIsExactOnMillimetreDepths) {
  // Depth images hold whole millimetres: then the binned medians and percentiles are the
  // readings' own. 800 object readings, 8 at each millimetre from 1.000 to 1.099 m, and 200
  // wall readings at 2.5 m.
  std::vector<double> values;
  for (int i = 0; i < 800; ++i) values.push_back(0.001 * (1000 + i / 8));
  for (int i = 0; i < 200; ++i) values.push_back(2.5);
  const RoiDepthStatistics s = robustDepthStatistics(values);
  EXPECT_EQ(s.used_pixels, 800);
  // Lower median: rank 399 -> 1000 + 49 mm.
  EXPECT_NEAR(s.median_m, 1.049, 1e-12);
  // MAD: distances 0..50 mm, 8 readings each but 16 for 1..49: rank 399 -> 25 mm.
  EXPECT_NEAR(s.mad_sigma_m, 1.4826 * 0.025, 1e-12);
  EXPECT_NEAR(s.min_m, 1.000, 1e-12);
  EXPECT_NEAR(s.max_m, 1.099, 1e-12);
  EXPECT_NEAR(s.mean_m, 1.0495, 1e-12);
  // Ranks 7 and 792 of the kept readings.
  EXPECT_NEAR(s.near_m, 1.000, 1e-12);
  EXPECT_NEAR(s.far_m, 1.099, 1e-12);
}

TEST(BoxEstimation, ZeroDepthIsIgnored) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(0.0);
  paint(depth, 100, 100, 120, 120, [](int, int) { return 1.0; });
  const auto box =
      expectBox(estimateBox(depth, k, {90, 90}, {130, 130}, BoxMode::kAxisAlignedFrontFace));
  EXPECT_EQ(box.stats.valid_pixels, 21 * 21);
  EXPECT_NEAR(box.stats.mean_m, 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Errors.

TEST(BoxEstimationErrors, RoiPartlyOrWhollyOutsideTheImage) {
  const CameraIntrinsics k;
  const cv::Mat depth = wall(1.0);
  EXPECT_EQ(expectError(estimateBox(depth, k, {600, 100}, {640, 200})),
            BoxEstimationError::kRoiOutsideImage);
  EXPECT_EQ(expectError(estimateBox(depth, k, {-1, 0}, {10, 10})),
            BoxEstimationError::kRoiOutsideImage);
  EXPECT_EQ(expectError(estimateBox(depth, k, {10, 10}, {20, 480})),
            BoxEstimationError::kRoiOutsideImage);
  EXPECT_EQ(expectError(estimateBox(depth, k, {-50, -50}, {-10, -10})),
            BoxEstimationError::kRoiOutsideImage);
  EXPECT_EQ(expectError(estimateBox(depth, k, {700, 500}, {900, 600})),
            BoxEstimationError::kRoiOutsideImage);
  // The last pixel is inside.
  EXPECT_TRUE(std::holds_alternative<BoxEstimate>(estimateBox(depth, k, {639, 479}, {639, 479})));
}

TEST(BoxEstimationErrors, EmptyImageMeansEmptyRoi) {
  const CameraIntrinsics k;
  EXPECT_EQ(expectError(estimateBox(cv::Mat(), k, {0, 0}, {0, 0})), BoxEstimationError::kEmptyRoi);
  EXPECT_EQ(expectError(estimateBox(cv::Mat(0, 0, CV_16UC1), k, {0, 0}, {1, 1})),
            BoxEstimationError::kEmptyRoi);
}

TEST(BoxEstimationErrors, NoValidDepthIsAnErrorNotABoxOfZeros) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(1.0);
  paint(depth, 10, 10, 50, 50, [](int, int) { return 0.0; });
  for (BoxMode mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    EXPECT_EQ(expectError(estimateBox(depth, k, {10, 10}, {50, 50}, mode)),
              BoxEstimationError::kNoValidDepth);
  }
  // Readings beyond max_valid_depth_m count as missing.
  paint(depth, 60, 60, 70, 70, [](int, int) { return 30.0; });
  EXPECT_EQ(expectError(estimateBox(depth, k, {60, 60}, {70, 70})),
            BoxEstimationError::kNoValidDepth);
}

TEST(BoxEstimationErrors, WrongTypeBadIntrinsicsUnknownMode) {
  const CameraIntrinsics k;
  EXPECT_EQ(
      expectError(estimateBox(cv::Mat(480, 640, CV_32FC1, cv::Scalar(1.0f)), k, {0, 0}, {10, 10})),
      BoxEstimationError::kInvalidArgument);
  CameraIntrinsics bad = k;
  bad.fx = 0.0;
  EXPECT_EQ(expectError(estimateBox(wall(1.0), bad, {0, 0}, {10, 10})),
            BoxEstimationError::kInvalidArgument);
  EXPECT_EQ(expectError(estimateBox(wall(1.0), k, {0, 0}, {10, 10}, static_cast<BoxMode>(0))),
            BoxEstimationError::kInvalidArgument);
  EXPECT_EQ(expectError(estimateBox(wall(1.0), k, {0, 0}, {10, 10}, static_cast<BoxMode>(4))),
            BoxEstimationError::kInvalidArgument);
}

// ---------------------------------------------------------------------------------------------
// Helpers: volume, containment, drawing.

TEST(BoxEstimationHelpers, VolumeAndContainmentOfAnAxisAlignedBox) {
  BoxCorners c{Eigen::Vector3d(-0.1, -0.2, 1.0), Eigen::Vector3d(0.3, -0.2, 1.0),
               Eigen::Vector3d(0.3, 0.1, 1.0),   Eigen::Vector3d(-0.1, 0.1, 1.0),
               Eigen::Vector3d(-0.1, -0.2, 1.5), Eigen::Vector3d(0.3, -0.2, 1.5),
               Eigen::Vector3d(0.3, 0.1, 1.5),   Eigen::Vector3d(-0.1, 0.1, 1.5)};
  EXPECT_NEAR(boxVolume(c), 0.4 * 0.3 * 0.5, 1e-12);
  EXPECT_TRUE(boxContains(c, {0.0, 0.0, 1.2}));
  EXPECT_TRUE(boxContains(c, {0.3, 0.1, 1.5}));  // a corner, on the boundary
  EXPECT_FALSE(boxContains(c, {0.31, 0.0, 1.2}));
  EXPECT_FALSE(boxContains(c, {0.0, -0.21, 1.2}));
  EXPECT_FALSE(boxContains(c, {0.0, 0.0, 0.99}));
  EXPECT_FALSE(boxContains(c, {0.0, 0.0, 1.51}));
  EXPECT_TRUE(boxContains(c, {0.0, 0.0, 1.51}, 0.02));
  // Collapsed in x: only its plane, but y and z still bound it.
  for (auto& p : c) p.x() = 0.05;
  EXPECT_NEAR(boxVolume(c), 0.0, 1e-12);
  EXPECT_TRUE(boxContains(c, {0.05, 0.0, 1.2}, 1e-9));
  EXPECT_FALSE(boxContains(c, {0.06, 0.0, 1.2}, 1e-9));
  EXPECT_FALSE(boxContains(c, {0.05, 0.5, 1.2}, 1e-9));
  EXPECT_FALSE(boxContains(c, {0.05, 0.0, 2.0}, 1e-9));
}

TEST(BoxEstimationHelpers, OrientedBoxContainsTheObjectPointsBetweenItsFaces) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(2.5);
  paint(depth, 500, 50, 600, 120, [](int, int) { return 1.0; });
  const auto box = expectBox(estimateBox(depth, k, {500, 50}, {600, 120}));
  const Eigen::Vector3d inside = 0.5 * (box.corners[0] + box.corners[6]);
  EXPECT_TRUE(boxContains(box.corners, inside));
  const Eigen::Vector3d axis = (box.corners[4] - box.corners[0]).normalized();
  EXPECT_FALSE(boxContains(box.corners, box.corners[0] - 0.01 * axis));
  EXPECT_FALSE(boxContains(box.corners, box.corners[6] + 0.01 * axis));
  // Prism volume: front-face area times thickness.
  const Eigen::Vector3d n =
      (box.corners[2] - box.corners[0]).cross(box.corners[3] - box.corners[1]);
  EXPECT_NEAR(boxVolume(box.corners), 0.5 * n.norm() * (box.corners[4] - box.corners[0]).norm(),
              1e-12);
}

TEST(BoxEstimationHelpers, DrawBoxDrawsTheProjectedEdgesAndSurvivesPointsBehindTheCamera) {
  const CameraIntrinsics k;
  cv::Mat depth = wall(2.5);
  paint(depth, 200, 150, 300, 250, tiltedX(200, 300, 1.0, 0.2));
  const auto box = expectBox(estimateBox(depth, k, {200, 150}, {300, 250}));
  cv::Mat image(480, 640, CV_8UC3, cv::Scalar::all(0));
  drawBox(image, k, box.corners, cv::Scalar(0, 255, 0));
  // Pixels on the front face's top edge are green; far away from the box nothing is drawn.
  EXPECT_GT(image.at<cv::Vec3b>(150, 250)[1], 100);
  EXPECT_EQ(cv::countNonZero(image(cv::Rect(0, 0, 100, 100)).reshape(1)), 0);

  // Corners straddling and wholly behind the camera: no crash, straddling edges still drawn.
  BoxCorners odd = box.corners;
  for (int i = 4; i < 8; ++i) odd[i].z() = -1.0;
  cv::Mat image2(480, 640, CV_8UC3, cv::Scalar::all(0));
  drawBox(image2, k, odd, cv::Scalar(255, 255, 255));
  EXPECT_GT(cv::countNonZero(image2.reshape(1)), 0);
  BoxCorners behind = box.corners;
  for (auto& c : behind) c.z() = -c.z();
  cv::Mat image3(480, 640, CV_8UC3, cv::Scalar::all(0));
  drawBox(image3, k, behind, cv::Scalar(255, 255, 255));
  EXPECT_EQ(cv::countNonZero(image3.reshape(1)), 0);
}

}  // namespace
}  // namespace shapesense
