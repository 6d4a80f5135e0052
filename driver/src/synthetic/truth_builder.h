#pragma once
// Ground truth of one frame: per-surface and per-object records, from the scene model and the
// label images the sensor model wrote.

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "scene_model.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::synthetic::detail {

/// Fills the per-surface and per-object records of a frame from its label images.
class TruthBuilder {
 public:
  TruthBuilder(const SceneModel& model, const Eigen::Isometry3d& world_from_camera,
               const CameraIntrinsics& intrinsics)
      : model_(model), world_from_camera_(world_from_camera), intrinsics_(intrinsics) {}

  /// Needs truth's label images; fills its records and world_from_camera.
  void build(TruthFrame& truth) const;

 private:
  /// Pixel counts per surface and object id, and each object's pixel bounds.
  struct LabelStatistics {
    std::vector<std::size_t> surface_pixels;
    std::vector<std::size_t> object_pixels;
    std::vector<cv::Rect> object_boxes;
  };
  LabelStatistics countLabels(const TruthFrame& truth) const;
  std::vector<TruthSurface> surfaceTruths(const LabelStatistics& labels) const;
  std::vector<TruthObject> objectTruths(const LabelStatistics& labels) const;

  /// The world plane in camera coordinates, oriented so the camera is on its positive side.
  Eigen::Vector4d cameraPlane(const Eigen::Vector4d& world_plane) const;
  /// Pose and box of one object (what needs no pixels).
  TruthObject objectTruth(const ObjectDef& def) const;

  // bowl_truth.cpp
  /// The bowl fields of `out` (box already filled) from the bowl's definition.
  void addBowlShape(const ObjectDef& def, const Eigen::Isometry3d& camera_from_object,
                    TruthObject& out) const;
  /// Area (pixels) of the projected outer shell of a bowl (TruthObject in camera coordinates);
  /// 0 when part of the bowl lies behind the camera plane.
  double bowlSilhouetteArea(const TruthObject& bowl) const;

  const SceneModel& model_;
  Eigen::Isometry3d world_from_camera_;
  const CameraIntrinsics& intrinsics_;
};

}  // namespace shapesense::synthetic::detail
