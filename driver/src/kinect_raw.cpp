#include "shapesense/driver/kinect_raw.h"

#include <cmath>
#include <stdexcept>

namespace shapesense {

double kinectRawToMetres(std::uint16_t raw, const KinectRawParams& params) {
  if (raw >= kKinectRawNoReading) return 0.0;
  const double inverse = params.inverse_depth_at_raw0 - params.inverse_depth_per_raw * raw;
  if (inverse <= 0.0) return 0.0;
  const double z = 1.0 / inverse;
  if (z < params.min_depth_m || z > params.max_depth_m) return 0.0;
  return z;
}

std::uint16_t kinectMetresToRaw(double z_m, const KinectRawParams& params) {
  if (!(z_m > 0.0) || z_m < params.min_depth_m || z_m > params.max_depth_m) {
    return kKinectRawNoReading;
  }
  const double raw = (params.inverse_depth_at_raw0 - 1.0 / z_m) / params.inverse_depth_per_raw;
  // Depths just nearer than raw 0 (0.3002 m by default) round to it.
  const double rounded = raw > -1.0 && raw < 0.0 ? 0.0 : std::round(raw);
  if (rounded < 0.0 || rounded >= kKinectRawNoReading) return kKinectRawNoReading;
  return static_cast<std::uint16_t>(rounded);
}

double kinectRawDepthStep(double z_m, const KinectRawParams& params) {
  return z_m * z_m * params.inverse_depth_per_raw;
}

KinectRawToMm::KinectRawToMm(const KinectRawParams& params) : params_(params) {
  for (int raw = 0; raw < kKinectRawValues; ++raw) {
    const double z = kinectRawToMetres(static_cast<std::uint16_t>(raw), params_);
    const double mm = std::round(z * 1000.0);
    table_[raw] = mm > 65535.0 ? 0 : static_cast<std::uint16_t>(mm);
  }
}

cv::Mat KinectRawToMm::convert(const cv::Mat& raw) const {
  if (raw.type() != CV_16UC1) throw std::invalid_argument("Kinect raw depth must be CV_16UC1");
  cv::Mat mm(raw.size(), CV_16UC1);
  for (int y = 0; y < raw.rows; ++y) {
    const auto* in = raw.ptr<std::uint16_t>(y);
    auto* out = mm.ptr<std::uint16_t>(y);
    for (int x = 0; x < raw.cols; ++x) out[x] = (*this)(in[x]);
  }
  return mm;
}

cv::Mat KinectRawToMm::convert(const std::uint16_t* raw, int width, int height) const {
  // The Mat header only wraps the buffer; convert() copies into a new image.
  const cv::Mat view(height, width, CV_16UC1, const_cast<std::uint16_t*>(raw));
  return convert(view);
}

cv::Mat kinectMmToRaw(const cv::Mat& depth_mm, const KinectRawParams& params) {
  if (depth_mm.type() != CV_16UC1) throw std::invalid_argument("depth must be CV_16UC1 mm");
  // One lookup per distinct millimetre value would need 64k entries; the direct formula is
  // cheap enough for a writer.
  cv::Mat raw(depth_mm.size(), CV_16UC1);
  for (int y = 0; y < depth_mm.rows; ++y) {
    const auto* in = depth_mm.ptr<std::uint16_t>(y);
    auto* out = raw.ptr<std::uint16_t>(y);
    for (int x = 0; x < depth_mm.cols; ++x) {
      out[x] = in[x] == 0 ? kKinectRawNoReading : kinectMetresToRaw(in[x] / 1000.0, params);
    }
  }
  return raw;
}

}  // namespace shapesense
