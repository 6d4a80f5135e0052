// What a bowl's truth reports beyond its box: rim, axis, dimensions, view and visible fraction.

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "truth_builder.h"
#include "world_geometry.h"

namespace shapesense::synthetic {

std::string bowlViewClass(double elevation_deg) {
  if (elevation_deg > 60.0) return "top";
  if (elevation_deg >= 20.0) return "middle";
  return "side";
}

namespace detail {

void TruthBuilder::addBowlShape(const ObjectDef& def, const Eigen::Isometry3d& camera_from_object,
                                TruthObject& out) const {
  const BowlDef& bowl = *def.bowl;
  out.upright = bowl.upright;
  out.rim_center = camera_from_object * Eigen::Vector3d(0.0, 0.0, bowl.rim_z);
  out.axis = out.rotation.col(2);
  out.rim_radius_m = bowl.rim_radius;
  out.depth_m = bowl.depth;
  out.shell_thickness_m = bowl.thickness;
  const Eigen::Vector3d rim_world = def.world_from_object * Eigen::Vector3d(0.0, 0.0, bowl.rim_z);
  const Eigen::Vector3d to_camera = (world_from_camera_.translation() - rim_world).normalized();
  out.view_elevation_deg = radToDeg(std::asin(std::clamp(to_camera.z(), -1.0, 1.0)));
  out.view_class = bowlViewClass(out.view_elevation_deg);
}

// The convex hull of points sampled densely on the spherical cap, which projects to a convex
// outline.
double TruthBuilder::bowlSilhouetteArea(const TruthObject& bowl) const {
  const double r = bowl.rim_radius_m, h = std::max(bowl.depth_m, 1e-4);
  const double sphere_r = (r * r + h * h) / (2.0 * h);
  const Eigen::Vector3d axis = bowl.axis.normalized();
  const Eigen::Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
  const Eigen::Vector3d centre = bowl.rim_center + axis * (sphere_r - h);
  const double polar_max = std::acos(std::clamp(1.0 - h / sphere_r, -1.0, 1.0));  // the rim
  constexpr int kPolar = 24, kAzimuth = 96;
  std::array<Eigen::Vector3d, kAzimuth> around;  // unit directions in the rim plane
  for (int j = 0; j < kAzimuth; ++j) {
    const double azimuth = 2.0 * std::numbers::pi * j / kAzimuth;
    around[static_cast<std::size_t>(j)] = std::cos(azimuth) * e1 + std::sin(azimuth) * e2;
  }
  std::vector<cv::Point2f> outline;
  outline.reserve((kPolar + 1) * kAzimuth);
  for (int i = 0; i <= kPolar; ++i) {
    const double polar = polar_max * i / kPolar;
    const double sin_polar = std::sin(polar), cos_polar = std::cos(polar);
    for (const Eigen::Vector3d& dir : around) {
      const Eigen::Vector3d p = centre + sphere_r * (sin_polar * dir - cos_polar * axis);
      if (p.z() < 0.01) return 0.0;
      const Eigen::Vector2d px = intrinsics_.project(p);
      outline.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
    }
  }
  std::vector<cv::Point2f> hull;
  cv::convexHull(outline, hull);
  return cv::contourArea(hull);
}

}  // namespace detail

}  // namespace shapesense::synthetic
