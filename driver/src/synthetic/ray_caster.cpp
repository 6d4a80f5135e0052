#include "ray_caster.h"

#include <algorithm>
#include <cmath>

#include "ray_span.h"

namespace shapesense::synthetic::detail {

void RayCaster::cast(const Primitive& primitive) {
  const Eigen::Isometry3d local_from_camera =
      primitive.world_from_local.inverse() * world_from_camera_;
  const cv::Rect rect = screenRect(primitive, local_from_camera.inverse());
  const Eigen::Matrix3d r = local_from_camera.linear();
  const Eigen::Vector3d origin = local_from_camera.translation();
  const Eigen::Vector3d du = r.col(0) / k_.fx;  // d(direction)/du
  const Solid& solid = *primitive.solid;
  LocalHit hit;
  for (int v = rect.y; v < rect.y + rect.height; ++v) {
    const Eigen::Vector3d row =
        r.col(1) * ((v - k_.cy) / k_.fy) + r.col(2) - r.col(0) * (k_.cx / k_.fx);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      const Eigen::Vector3d direction = row + du * u;
      if (!solid.intersect(origin, direction, hit)) continue;
      const std::size_t i = hits_.index(u, v);
      if (hit.t >= hits_.depth[i]) continue;
      hits_.depth[i] = static_cast<float>(hit.t);
      hits_.surface[i] = primitive.surface_of_face[static_cast<std::size_t>(hit.face)];
      hits_.object[i] = primitive.object_id;
      hits_.normal[i] = (r.transpose() * hit.normal).cast<float>();
    }
  }
}

cv::Rect RayCaster::screenRect(const Primitive& primitive,
                               const Eigen::Isometry3d& camera_from_local) const {
  const cv::Rect all(0, 0, hits_.width, hits_.height);
  const Eigen::AlignedBox3d box = primitive.solid->bounds();
  double u0 = kInf, v0 = kInf, u1 = -kInf, v1 = -kInf;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p =
        camera_from_local * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
    if (p.z() < 1e-3) return all;  // straddles the camera plane: no cheap bound
    const Eigen::Vector2d px = k_.project(p);
    u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x());
    v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
  }
  const double clamp_lo = -1e6, clamp_hi = 1e6;  // keep the int conversion defined
  const int x0 = static_cast<int>(std::floor(std::clamp(u0, clamp_lo, clamp_hi))) - 1;
  const int y0 = static_cast<int>(std::floor(std::clamp(v0, clamp_lo, clamp_hi))) - 1;
  const int x1 = static_cast<int>(std::ceil(std::clamp(u1, clamp_lo, clamp_hi))) + 2;
  const int y1 = static_cast<int>(std::ceil(std::clamp(v1, clamp_lo, clamp_hi))) + 2;
  return cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1)) & all;
}

}  // namespace shapesense::synthetic::detail
