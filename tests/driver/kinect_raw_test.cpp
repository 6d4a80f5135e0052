// Kinect v1 raw 11-bit depth <-> millimetres: the lookup table against the formula, the
// monotonic range, the z^2 quantisation step, and the mm -> raw -> mm round trip.

#include "shapesense/driver/kinect_raw.h"

#include <gtest/gtest.h>

#include <cmath>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {
namespace {

TEST(KinectRaw, KnownValuesOfTheBurrusCalibration) {
  // 1/z = 3.3309495161 - 0.0030711016 raw
  EXPECT_NEAR(kinectRawToMetres(0), 1.0 / 3.3309495161, 1e-9);
  EXPECT_NEAR(kinectRawToMetres(500), 1.0 / (3.3309495161 - 0.0030711016 * 500), 1e-9);
  EXPECT_NEAR(kinectRawToMetres(758), 1.0 / (3.3309495161 - 0.0030711016 * 758), 1e-9);
  // Typical Kinect readings: ~0.6 m at raw ~560, ~1 m at ~760, ~2 m at ~922, ~4 m at ~1003.
  EXPECT_NEAR(kinectRawToMetres(760), 1.0, 0.01);
  EXPECT_NEAR(kinectRawToMetres(922), 2.0, 0.05);
  EXPECT_NEAR(kinectRawToMetres(1003), 4.0, 0.1);
}

TEST(KinectRaw, NoReadingAndOutOfRangeGiveZero) {
  EXPECT_EQ(kinectRawToMetres(kKinectRawNoReading), 0.0);
  EXPECT_EQ(kinectRawToMetres(1084), 0.0);  // beyond max_depth (10 m)
  EXPECT_EQ(kinectRawToMetres(1085), 0.0);  // negative inverse depth: past infinity
  EXPECT_EQ(kinectRawToMetres(2000), 0.0);
  const KinectRawToMm table;
  EXPECT_EQ(table(kKinectRawNoReading), 0);
  EXPECT_EQ(table(1500), 0);
  EXPECT_EQ(kinectMetresToRaw(0.0), kKinectRawNoReading);
  EXPECT_EQ(kinectMetresToRaw(-1.0), kKinectRawNoReading);
  EXPECT_EQ(kinectMetresToRaw(0.2), kKinectRawNoReading);
  EXPECT_EQ(kinectMetresToRaw(12.0), kKinectRawNoReading);
}

TEST(KinectRaw, TableMatchesFormulaToTheMillimetre) {
  const KinectRawToMm table;
  int valid = 0;
  for (int raw = 0; raw < kKinectRawValues; ++raw) {
    const double z = kinectRawToMetres(static_cast<std::uint16_t>(raw));
    const std::uint16_t mm = table(static_cast<std::uint16_t>(raw));
    if (z == 0.0) {
      EXPECT_EQ(mm, 0) << raw;
      continue;
    }
    ++valid;
    EXPECT_LE(std::abs(mm - z * 1000.0), 0.5) << "raw " << raw;
  }
  // raw 0 (0.30 m) .. ~1053 (10 m) are valid.
  EXPECT_GT(valid, 1000);
  EXPECT_LT(valid, 1084);
}

TEST(KinectRaw, DepthIncreasesMonotonicallyOverTheValidRange) {
  const KinectRawToMm table;
  std::uint16_t previous = 0;
  bool in_range = false;
  for (int raw = 0; raw < kKinectRawValues; ++raw) {
    const std::uint16_t mm = table(static_cast<std::uint16_t>(raw));
    if (mm == 0) {
      if (in_range) in_range = false;  // the valid range ends once
      continue;
    }
    ASSERT_FALSE(previous != 0 && !in_range) << "second valid range at raw " << raw;
    EXPECT_GE(mm, previous) << raw;
    EXPECT_GT(kinectRawToMetres(static_cast<std::uint16_t>(raw)),
              raw > 0 ? kinectRawToMetres(static_cast<std::uint16_t>(raw - 1)) : 0.0);
    previous = mm;
    in_range = true;
  }
  EXPECT_GE(previous, 9900);  // reaches ~10 m
}

TEST(KinectRaw, QuantisationStepGrowsWithTheSquareOfRange) {
  for (double z : {0.6, 1.0, 2.0, 3.0, 4.5, 8.0}) {
    const std::uint16_t raw = kinectMetresToRaw(z);
    const double step = kinectRawToMetres(raw + 1) - kinectRawToMetres(raw);
    const double predicted = kinectRawDepthStep(z);
    EXPECT_NEAR(step / predicted, 1.0, 0.05) << "z = " << z;
    // The same law as the project's noise model, with f*b = disparity_step / per_raw.
    const KinectNoiseModel model{.focal_baseline_px_m = 0.125 / 0.0030711016,
                                 .disparity_step_px = 0.125};
    EXPECT_NEAR(step / model.depthStep(z), 1.0, 0.05) << "z = " << z;
  }
  const double step1 = kinectRawDepthStep(1.0), step3 = kinectRawDepthStep(3.0);
  EXPECT_NEAR(step3 / step1, 9.0, 1e-9);
  EXPECT_NEAR(step1, 0.0031, 0.0001);  // 3.1 mm at 1 m
  EXPECT_NEAR(step3, 0.0276, 0.0005);  // 2.8 cm at 3 m
}

TEST(KinectRaw, MillimetreRoundTripIsWithinHalfARawStep) {
  const KinectRawToMm table;
  double worst_ratio = 0.0;
  for (int mm = 300; mm <= 10000; ++mm) {
    const double z = mm / 1000.0;
    const std::uint16_t raw = kinectMetresToRaw(z);
    ASSERT_NE(raw, kKinectRawNoReading) << mm;
    const double back = table(raw);
    const double bound = 1000.0 * kinectRawDepthStep(z) / 2.0 * 1.02 + 0.5;
    ASSERT_LE(std::abs(back - mm), bound) << mm << " mm -> raw " << raw << " -> " << back;
    worst_ratio = std::max(worst_ratio, std::abs(back - mm) / bound);
    // The raw is the nearest: its neighbours are not closer in inverse depth.
    const double inv = 1.0 / z;
    const auto inverse_gap = [&](int r) {
      return std::abs(1.0 / kinectRawToMetres(static_cast<std::uint16_t>(r)) - inv);
    };
    if (raw > 0) {
      EXPECT_LE(inverse_gap(raw), inverse_gap(raw - 1) + 1e-12);
    }
    if (kinectRawToMetres(raw + 1) > 0) {
      EXPECT_LE(inverse_gap(raw), inverse_gap(raw + 1) + 1e-12);
    }
  }
  EXPECT_GT(worst_ratio, 0.5);  // the bound is tight, not vacuous
}

TEST(KinectRaw, ImageConversionsKeepNoReadingAndShape) {
  cv::Mat mm(3, 4, CV_16UC1, cv::Scalar(0));
  mm.at<std::uint16_t>(0, 0) = 1000;
  mm.at<std::uint16_t>(1, 2) = 2500;
  mm.at<std::uint16_t>(2, 3) = 20000;  // beyond range -> no reading
  const cv::Mat raw = kinectMmToRaw(mm);
  ASSERT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 1), kKinectRawNoReading);
  EXPECT_EQ(raw.at<std::uint16_t>(2, 3), kKinectRawNoReading);
  const cv::Mat back = KinectRawToMm().convert(raw);
  ASSERT_EQ(back.size(), mm.size());
  EXPECT_NEAR(back.at<std::uint16_t>(0, 0), 1000, 2);
  EXPECT_NEAR(back.at<std::uint16_t>(1, 2), 2500, 10);
  EXPECT_EQ(back.at<std::uint16_t>(0, 1), 0);
  EXPECT_EQ(back.at<std::uint16_t>(2, 3), 0);
  EXPECT_THROW(KinectRawToMm().convert(cv::Mat(2, 2, CV_8UC1)), std::invalid_argument);
}

}  // namespace
}  // namespace shapesense
