#include "face_scene.h"

#include <cmath>

namespace shapesense::testing {

std::uint16_t kinectDepthMm(double range_m, std::mt19937& rng, double disparity_sigma_px) {
  constexpr double kFocalBaseline = 43.5;  // focal length (px) times baseline (m), over 8
  constexpr double kDisparityStep = 0.125;
  std::normal_distribution<double> noise(0.0, disparity_sigma_px);
  double disparity = kFocalBaseline / range_m + noise(rng);
  disparity = std::round(disparity / kDisparityStep) * kDisparityStep;
  return static_cast<std::uint16_t>(std::lround(1e3 * kFocalBaseline / disparity));
}

std::optional<double> Face::rangeAt(const Eigen::Vector3d& ray) const {
  const double denom = normal.dot(ray);
  if (std::fabs(denom) < 1e-9) return std::nullopt;
  const Eigen::Vector3d p = ray * (normal.dot(edge) / denom);
  const double s = (p - edge).dot(along);
  if (p.z() <= 0.0 || s < 0.0 || s > width || std::fabs(p.y()) > half_height) return std::nullopt;
  return p.z();
}

FaceFrame renderFaces(const std::vector<Face>& faces, double wall_m, unsigned seed,
                      double disparity_sigma_px) {
  const CameraIntrinsics K;  // Kinect v1
  FaceFrame out{cv::Mat(K.height, K.width, CV_16UC1), cv::Mat(K.height, K.width, CV_8UC1)};
  std::mt19937 rng(seed);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector3d ray = K.ray(u, v);
      double z = wall_m;
      std::uint8_t seen = 0;
      for (std::size_t i = 0; i < faces.size(); ++i)
        if (const auto range = faces[i].rangeAt(ray); range && *range < z) {
          z = *range;
          seen = static_cast<std::uint8_t>(i + 1);
        }
      out.depth.at<std::uint16_t>(v, u) = kinectDepthMm(z, rng, disparity_sigma_px);
      out.face.at<std::uint8_t>(v, u) = seen;
    }
  return out;
}

}  // namespace shapesense::testing
