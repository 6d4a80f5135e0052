#include "camera_pose.h"

#include <cmath>
#include <numbers>

#include "world_geometry.h"

namespace shapesense::synthetic::detail {

Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double roll) {
  const Eigen::Vector3d forward = (target - eye).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = right;
  pose.linear().col(1) = down;
  pose.linear().col(2) = forward;
  pose.linear() =
      pose.linear() * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = eye;
  return pose;
}

Eigen::Isometry3d Sway::at(double seconds, double scale) const {
  std::array<double, 6> v{};
  for (std::size_t i = 0; i < 6; ++i)
    v[i] = scale * amplitude[i] *
           std::sin(2.0 * std::numbers::pi * frequency_hz[i] * seconds + phase[i]);
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  offset.linear() = (Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()))
                        .toRotationMatrix();
  return offset;
}

Sway drawSway(Rng& rng) {
  Sway s;
  for (std::size_t i = 0; i < 6; ++i) {
    s.amplitude[i] = i < 3 ? rng.uniform(0.01, 0.03) : degToRad(rng.uniform(0.4, 1.0));
    s.frequency_hz[i] = 1.0 / rng.uniform(3.0, 9.0);
    s.phase[i] = rng.uniform(0.0, 2.0 * std::numbers::pi);
  }
  return s;
}

}  // namespace shapesense::synthetic::detail
