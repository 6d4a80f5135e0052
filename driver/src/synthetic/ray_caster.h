#pragma once
// Ideal depth: the first surface hit along each camera ray, with what it belongs to.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "scene_model.h"
#include "shapesense/core/geometry/camera.h"

namespace shapesense::synthetic::detail {

/// Nearest hit per pixel. Holds extra columns right of the image: occluders there can still
/// shadow image pixels from the projector, which sits to the right of the camera.
struct HitBuffer {
  int width = 0;  ///< including the extra columns
  int height = 0;
  std::vector<float> depth;  ///< ray parameter = z; +inf where nothing was hit
  std::vector<std::uint16_t> surface;
  std::vector<std::uint16_t> object;
  std::vector<Eigen::Vector3f> normal;  ///< camera frame, unit

  HitBuffer(int w, int h)
      : width(w),
        height(h),
        depth(static_cast<std::size_t>(w) * h, std::numeric_limits<float>::infinity()),
        surface(depth.size(), 0),
        object(depth.size(), 0),
        normal(depth.size(), Eigen::Vector3f::Zero()) {}
  std::size_t index(int u, int v) const { return static_cast<std::size_t>(v) * width + u; }
};

/// Casts the camera rays of one frame against every primitive. Rays are parameterised as
/// X = t * (x/z, y/z, 1) in the camera frame, so the ray parameter t of the first hit IS the
/// depth z.
class RayCaster {
 public:
  RayCaster(const CameraIntrinsics& k, const Eigen::Isometry3d& world_from_camera, HitBuffer& hits)
      : k_(k), world_from_camera_(world_from_camera), hits_(hits) {}

  /// Keeps, per pixel, the nearer of the buffer's hit and the primitive's.
  void cast(const Primitive& primitive);

 private:
  /// Pixels the primitive can cover: the bounds of its projected bounding box.
  cv::Rect screenRect(const Primitive& primitive, const Eigen::Isometry3d& camera_from_local) const;

  const CameraIntrinsics& k_;
  Eigen::Isometry3d world_from_camera_;
  HitBuffer& hits_;
};

}  // namespace shapesense::synthetic::detail
