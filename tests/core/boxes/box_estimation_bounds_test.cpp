// estimateBox with intrinsics and parameters no camera has: every derived size (histogram bins,
// window) stays bounded, and the request is refused instead of crashing. fx = fy = 0.001 in a
// recording's camera.json once made a mode 1 request allocate 2.5 GB and crash the daemon
// (float-to-int overflow of the window's half width), and 1e-300 grew it to 7 GB.

#include <gtest/gtest.h>

#include <limits>
#include <variant>

#include "shapesense/core/boxes/box_estimation.h"

namespace shapesense {
namespace {

// The request: a 640x480 frame, ROI (200,150)-(400,350).
std::variant<BoxEstimate, BoxEstimationFailure> estimateWithFocal(double focal, BoxMode mode) {
  const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(1500));
  CameraIntrinsics k;
  k.fx = focal;
  k.fy = focal;
  return estimateBox(depth, k, {200, 150}, {400, 350}, mode);
}

void expectRefused(double focal) {
  for (BoxMode mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    SCOPED_TRACE("fx = fy = " + std::to_string(focal) + ", mode " +
                 std::to_string(static_cast<int>(mode)));
    const auto result = estimateWithFocal(focal, mode);
    ASSERT_TRUE(std::holds_alternative<BoxEstimationFailure>(result));
    EXPECT_EQ(std::get<BoxEstimationFailure>(result).code, BoxEstimationError::kInvalidArgument);
    EXPECT_NE(std::get<BoxEstimationFailure>(result).message.find("optical axis"),
              std::string::npos);
  }
}

TEST(BoxEstimationBounds, MilliPixelFocalLengthIsRefused) { expectRefused(0.001); }

TEST(BoxEstimationBounds, DenormalScaleFocalLengthIsRefused) { expectRefused(1e-300); }

TEST(BoxEstimationBounds, WidestPinholeCameraStillEstimates) {
  // A 160-degree field of view (fx = 640 / (2 tan 80 deg)), ROI in the image corner.
  const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(1500));
  CameraIntrinsics k;
  k.fx = k.fy = 56.5;
  const auto result = estimateBox(depth, k, {0, 0}, {20, 20}, BoxMode::kFrustumAligned);
  ASSERT_TRUE(std::holds_alternative<BoxEstimate>(result));
  EXPECT_EQ(std::get<BoxEstimate>(result).stats.used_pixels, 21 * 21);
}

TEST(BoxEstimationBounds, WindowWiderThanTheHistogramKeepsEveryReading) {
  // A window of 1e300 m: its half width in bins does not fit an int.
  BoxEstimationParams params;
  params.inlier_sigmas = 1e300;
  const RoiDepthStatistics stats = robustDepthStatistics({1.0, 1.1, 1.2, 5.0}, params);
  EXPECT_EQ(stats.used_pixels, 4);
  EXPECT_DOUBLE_EQ(stats.min_m, 1.0);
  EXPECT_DOUBLE_EQ(stats.max_m, 5.0);
}

TEST(BoxEstimationBounds, NotANumberWindowKeepsTheCentreOnly) {
  BoxEstimationParams params;
  params.inlier_sigmas = std::numeric_limits<double>::quiet_NaN();
  const RoiDepthStatistics stats = robustDepthStatistics({1.0, 1.1, 1.2, 5.0}, params);
  EXPECT_EQ(stats.used_pixels, 1);
}

}  // namespace
}  // namespace shapesense
