#pragma once
// The Kinect v1 sensor model (see KinectParams) and the colour camera, applied to the ideal hits
// of one frame.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "random.h"
#include "ray_caster.h"
#include "scene_model.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::synthetic::detail {

/// Columns right of the image whose occluders can shadow image pixels from the projector
/// (nearer occluders are below the sensor's minimum range and ignored); 0 without shadows.
int projectorShadowColumns(const SceneParams& params);

/// Pixels whose surface point the IR projector (at +baseline along camera x) cannot see, one
/// byte per image pixel (the extra columns of `hits` excluded).
std::vector<std::uint8_t> projectorShadows(const HitBuffer& hits, int image_width, double fx,
                                           double baseline);

/// Turns the ideal hits into what a Kinect v1 reports, plus colour and label images.
class SensorModel {
 public:
  SensorModel(const SceneParams& params, const SceneModel& model, std::uint64_t index);

  /// Fills frame.depth (and frame.rgb) and truth's label and ideal depth images.
  void apply(const HitBuffer& hits, const Eigen::Isometry3d& world_from_camera, Frame& frame,
             TruthFrame& truth) const;

 private:
  void allocateImages(Frame& frame, TruthFrame& truth) const;
  /// What the sensor reads (m) at `pixel` whose ideal depth is z, surface normal n and viewing
  /// ray `ray`; 0 when it reads nothing (grazing, dropout, out of range).
  double reading(std::size_t pixel, double z, const Eigen::Vector3f& n,
                 const Eigen::Vector3f& ray) const;
  /// The frame's holes (KinectParams::holes_*): non-zero where the sensor reads nothing; empty
  /// when holes are off.
  cv::Mat holeMask() const;
  /// The depth the sensor measures from at an edge pixel (KinectParams::flying_pixel_rate): z
  /// moved towards the neighbour across the edge, or z itself.
  double flyingDepth(const HitBuffer& hits, int u, int v, std::size_t pixel, double z) const;
  /// z -> noisy, quantised disparity -> z; 0 when the disparity is not positive.
  double measure(double z, double standard_normal) const;
  cv::Vec3b shade(std::uint16_t surface, const Eigen::Vector3f& normal,
                  const Eigen::Vector3f& light, std::uint64_t bits) const;

  // Which PixelNoise draws each use of noise takes.
  static constexpr unsigned kDropoutDraw = 0;
  static constexpr unsigned kColourDraw = 1;
  static constexpr unsigned kDisparityDraw = 2;  // and up
  // Which artefacts_ draws each artefact takes (a stream of its own: off, they draw nothing).
  static constexpr unsigned kFlyingDraw = 0;  // and 1
  static constexpr unsigned kHoleDraw = 2;    // pixel 0 only: seeds the hole generator

  const SceneParams& params_;
  const SceneModel& model_;
  PixelNoise noise_;
  PixelNoise artefacts_;
  double cos_max_incidence_;
};

}  // namespace shapesense::synthetic::detail
