#pragma once
// A box with its own axes, and the one around a set of points along their principal axes: an
// object model's extent, and the extent of a scene's cluster of surface.

#include <vector>

#include <Eigen/Core>

namespace shapesense {

/// A box with its own axes: corner = centre + axes * (+-size / 2) per axis.
struct OrientedBox {
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  Eigen::Matrix3f axes = Eigen::Matrix3f::Identity();  ///< columns, unit and orthogonal
  Eigen::Vector3f size = Eigen::Vector3f::Zero();      ///< full extent along each axis (m)
};

/// The box along the principal axes of `points` that holds them all (a right-handed frame).
OrientedBox principalBox(const std::vector<Eigen::Vector3f>& points);

}  // namespace shapesense
