#pragma once
// A step of planes_and_objects: what each object region's points say of its shape. Whether it
// is one face, two faces at a crease, or a piece of a curved surface, and whether two curved
// regions are pieces of one.

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "segmentation/segmentation_kernels.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/height_fit.h"
#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/geometry/quadric_surface.h"
#include "shapesense/core/geometry/two_plane_fit.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::segmentation {

/// The runs of equal labels of every row.
using RowRuns = std::vector<std::vector<LabelRun>>;

/// Each object region's sample points (every curved_sample_step_px pixels), plane normal and
/// height fits, and whether it lies on a curved surface: a quadric fits its points markedly
/// better than their plane and bends as no flat face seen through the sensor's noise does, or
/// it is no plane and one quadric surface holds its points. Planes (labels up to plane_count)
/// have no samples and are not curved.
struct ObjectShapes {
  std::vector<std::vector<Eigen::Vector3d>> points;
  std::vector<std::optional<TwoPlanes>> faces;  ///< of the regions that are two faces at a crease
  std::vector<PlaneMoments> moments;
  std::vector<Eigen::Vector3d> normal;
  std::vector<HeightFit> fit;
  std::vector<QuadricSurfaceFit> surface;  ///< of the curved regions and those that are no plane
  std::vector<bool> curved;
};

/// The shapes of the object regions (labels above plane_count, up to label_count) of the label
/// image whose runs are `runs`.
ObjectShapes objectShapes(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                          const RowRuns& runs, int plane_count, int label_count,
                          const PlanesAndObjectsParams& p);

/// Whether one quadric fits curved regions a and b together about as well as their own quadrics
/// fit each, as a height field or as an implicit surface: pieces of one ball, bowl or bin do,
/// two tins side by side do not.
bool oneQuadricFitsBoth(const ObjectShapes& shapes, int a, int b, const PlanesAndObjectsParams& p);

}  // namespace shapesense::segmentation
