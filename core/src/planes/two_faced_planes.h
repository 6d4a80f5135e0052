#pragma once
// Step 4b of HoughPlaneDetector::detect (hough_detector_steps.h), and the test the leftover step
// shares: planes whose samples lie on two faces at a crease, split in two.

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/geometry/two_plane_fit.h"
#include "shapesense/core/planes/plane_labeling.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

/// The points of the grid samples `members` (indices), in their order, into `points`.
void gatherSamplePoints(const PlaneSampleGrid& grid, const std::vector<int>& members,
                        std::vector<Eigen::Vector3d>& points);

/// Whether `count` sample points may be two faces at all (twoFaces needs the test on and each
/// face holding twice min_plane_samples): callers skip gathering the points of those that
/// cannot.
bool mayBeTwoFaces(std::size_t count, const HoughPlaneParams& P);

/// The two faces of the sample points `points`, whose plane `one` is, when two planes fit them
/// HoughPlaneParams::two_face_gain times better than `one` by RMS distance and each face holds
/// twice min_plane_samples (see two_face_gain for why). Twice the plane minimum: the curvature
/// check after the labelling must still tell a face cut from a curved surface (half of a tin's
/// side at range) from a flat one, which it cannot on a few dozen samples.
std::optional<TwoPlanes> twoFaces(std::span<const Eigen::Vector3d> points, const PlaneFit& one,
                                  const HoughPlaneParams& P);

/// Each member (grid index; `points` its point, aligned) takes the label of the nearer face,
/// label_a or label_b; with `member_tol` (aligned too) only when within its tolerance of that
/// face.
void labelNearerFace(const TwoPlanes& faces, const std::vector<int>& members,
                     std::span<const Eigen::Vector3d> points, int label_a, int label_b,
                     const std::vector<double>* member_tol, cv::Mat& sample_labels);

/// Step 4b: each plane whose samples are two faces (twoFaces) becomes two, the first in its
/// place, the second appended, each with the samples nearer it.
void splitTwoFacedPlanes(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                         std::vector<PlaneHypothesis>& planes, const HoughPlaneParams& P);

}  // namespace shapesense
