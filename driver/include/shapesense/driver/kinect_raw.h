#pragma once
// Kinect v1 raw depth: the 11-bit value the sensor sends (FREENECT_DEPTH_11BIT, one uint16 per
// pixel, 2047 = no reading) is a shifted, scaled disparity. Inverse depth is linear in it:
//
//     1 / z[m] = inverse_depth_at_raw0 - inverse_depth_per_raw * raw
//
// The defaults are N. Burrus' published Kinect v1 calibration (1/z = 3.3309495161 -
// 0.0030711016 raw), good to ~1% on typical units; a unit's own calibration can be put in the
// params. One raw step is a constant step in inverse depth, so the depth step grows as z^2:
//
//     dz/draw = z^2 * inverse_depth_per_raw    (3.1 mm at 1 m, 28 mm at 3 m, 62 mm at 4.5 m)
//
// which is KinectNoiseModel::depthStep with focal_baseline = disparity_step / per_raw (~40.7).
//
// Round trip mm -> raw -> mm (the fakenect dump writer uses mmToRaw): the raw is the nearest
// one in inverse depth, so the error is at most half a raw step (z^2 * per_raw / 2, i.e.
// 1.6 mm at 1 m, 31 mm at 4.5 m) plus 0.5 mm of millimetre rounding.

#include <array>
#include <cstdint>

#include <opencv2/core.hpp>

namespace shapesense {

/// The 11-bit value meaning "no reading".
inline constexpr std::uint16_t kKinectRawNoReading = 2047;
/// Number of distinct raw values (11 bits).
inline constexpr int kKinectRawValues = 2048;

struct KinectRawParams {
  double inverse_depth_at_raw0 = 3.3309495161;  ///< 1/m at raw 0. Default: Burrus.
  double inverse_depth_per_raw = 0.0030711016;  ///< 1/m per raw step. Default: Burrus.
  /// Readings nearer than this (m) become 0 (raw 0 is ~0.30 m). Default 0.3.
  double min_depth_m = 0.3;
  /// Readings farther than this (m) become 0; beyond ~10 m the sensor reports noise. Default 10.
  double max_depth_m = 10.0;
};

/// Depth (m) of a raw value, or 0 when it is 2047, beyond the raw of infinite depth, or
/// outside [min_depth_m, max_depth_m].
double kinectRawToMetres(std::uint16_t raw, const KinectRawParams& params = {});

/// The raw value whose depth is nearest to z in inverse depth; kKinectRawNoReading when z <= 0
/// or z is outside [min_depth_m, max_depth_m].
std::uint16_t kinectMetresToRaw(double z_m, const KinectRawParams& params = {});

/// Depth step (m) between neighbouring raw values at range z: z^2 * inverse_depth_per_raw.
double kinectRawDepthStep(double z_m, const KinectRawParams& params = {});

/// The 2048-entry raw -> millimetre lookup table (0 = no reading), built once from the formula
/// with rounding to whole millimetres. Converting an image is one lookup per pixel.
class KinectRawToMm {
 public:
  explicit KinectRawToMm(const KinectRawParams& params = {});

  /// Millimetres of one raw value (values above 2047 are masked to 11 bits).
  std::uint16_t operator()(std::uint16_t raw) const { return table_[raw & 0x7FF]; }

  /// CV_16UC1 raw image -> CV_16UC1 millimetre image. Throws std::invalid_argument on type.
  cv::Mat convert(const cv::Mat& raw) const;
  /// Converts `width` x `height` raw pixels (one native uint16 each, row-major).
  cv::Mat convert(const std::uint16_t* raw, int width, int height) const;

  const KinectRawParams& params() const { return params_; }

 private:
  KinectRawParams params_;
  std::array<std::uint16_t, kKinectRawValues> table_{};
};

/// CV_16UC1 millimetre image -> CV_16UC1 raw image (0 mm -> 2047). Inverse of KinectRawToMm
/// within the quantisation described at the top of this file.
cv::Mat kinectMmToRaw(const cv::Mat& depth_mm, const KinectRawParams& params = {});

}  // namespace shapesense
