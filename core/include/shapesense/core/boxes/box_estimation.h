#pragma once
// Rough 3D bounding box of an object from a 2D region of interest (ROI) in a depth frame.
//
// The ROI has one dimension less than the box, so it must be interpreted; the three modes are
// the three interpretations of the design (D4.6.2 section 3.1, "3D localization in the
// environment"). Every mode has the same two ingredients:
//   1. a robust near/far distance of the object from the ROI's depth readings (zeros ignored);
//   2. the mode's geometry, which turns the ROI's viewing frustum plus near/far into 8 corners.
//
// Robust statistics (why not the seed's plain mean/std over the whole ROI): an ROI around an
// object on a table also contains table and wall pixels, and a plain std over them inflates
// the box by the object-to-wall distance. We take the median of the ROI's values as the
// object's centre (the object covers most of its own ROI, so the median lands on it), estimate
// the object's spread with the MAD (1.4826 * median absolute deviation, a std estimate that a
// minority of far pixels cannot move much), keep the readings within `inlier_sigmas` MAD-sigmas
// of the median (re-centred `refine_iterations` times on the kept set), and only then take the
// seed's mean and std over the kept readings. The faces go at mean -/+ `std_scale` * std: the
// seed's factor of 1 covers only ~58 % of an evenly spread object (a box's visible surfaces),
// so the default widens it, and each face is clamped to the kept readings' trimmed range (no
// face beyond the 1st / 99th percentile of the object's readings); see BoxEstimationParams.
//
// Geometry conventions: OpenCV camera frame (x right, y down, z forward), metres. The ROI's
// corners are inclusive pixel indices; pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5,
// v + 0.5], so the ROI's frustum is spanned by the rays through the ROI's *outer pixel edges*
// (see `roi_pixel_margin`). That is what makes a 1x1 ROI a valid, non-degenerate box.
//
// "Focal plane" rule: the seed moves the box back when a front corner would come closer to the
// camera than "the focal length" (its own code left this disabled because focal lengths are in
// pixels and depths in metres). For a metric camera the physically meaningful plane is the
// sensor's near limit: nothing closer than it can produce a depth reading, so no object box
// can start there. We use the plane z = `min_front_depth_m` (default 0.4 m, the Kinect v1's
// near-mode limit; in default mode it reads from ~0.5 m). When a front corner's z is below it,
// the box moves back so that its nearest front corner lies on the plane; the depth extent
// (far - near) is kept, so the box keeps its size rather than being squashed, and each mode's
// invariants (corners on the frustum edges / front face projecting onto the ROI) are kept.

#include <array>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

/// How the ROI is interpreted (values are the design's mode numbers, also used on the wire).
enum class BoxMode {
  /// Default. The ROI is the projection of the box's front face; the box is turned to fit the
  /// ROI's viewing frustum: its front face is perpendicular to the frustum's central axis (the
  /// ray through the ROI centre) and the four front corners lie on the four frustum edge rays.
  /// Depth readings are converted to distances from the optical centre; the front face passes
  /// through the axis point at distance `near`, the back face through the one at `far`, and the
  /// back face is the front face translated along the axis (so the box is a right prism: a
  /// rectangular box when the ROI is centred on the principal point, otherwise its front face
  /// is the slightly trapezoidal section of the frustum). Back corners lie just outside the
  /// frustum edges, as in the seed's implementation.
  kFrustumAligned = 1,
  /// The ROI contains the whole projection of an axis-aligned box whose front face is at
  /// Z = near and back face at Z = far. Per axis the box is the widest whose projection stays
  /// inside the ROI: an ROI edge on the far side of the principal point bounds the back face
  /// (seed: T1 on edge t1 at Zmean + Zstd), one on the near side bounds the front face (T2 on t2
  /// at Zmean - Zstd); an ROI that straddles the principal point is bounded by the front face
  /// on both sides. When the two bounds cross (a deep box in a narrow, off-centre ROI: no box of
  /// that depth fits) that coordinate collapses to the mean of the two bounds, as in the seed.
  kAxisAlignedContained = 2,
  /// The ROI is the projection of the front face of an axis-aligned box: front face at
  /// Z = near spanning exactly the ROI's frustum, back face the same rectangle at Z = far.
  kAxisAlignedFrontFace = 3,
  /// The ROI marks an object: the box is that of the segments lying mostly inside the ROI,
  /// minus the plane they stand on (boxFromSegments in segment_box.h; it needs the frame's
  /// segmentation and planes, so estimateBox refuses this mode).
  kSegments = 4,
};

/// Tunables of estimateBox. Defaults suit a Kinect v1 at 0.5 - 4 m.
struct BoxEstimationParams {
  /// Faces at mean -/+ std_scale * std of the kept readings (then clamped, see
  /// clamp_to_kept_range). The seed uses 1, which cuts an evenly spread object (what a box's
  /// visible faces produce; it spans mean +/- sqrt(3) * std) by ~40 % in depth. Tuned on the
  /// synthetic scenes (tests/core/box_estimation_synthetic_test.cpp): containment rises up to
  /// ~2.5 and is flat beyond, because the clamp then binds for most objects.
  double std_scale = 2.5;
  /// Readings farther than inlier_sigmas * sigma from the median are background (table beyond
  /// the object, wall, flying pixels). 3 keeps all of an evenly spread object (its extremes are
  /// at ~2.3 MAD-sigmas) and 99.7 % of Gaussian noise; 4 lets in more table for no gain.
  double inlier_sigmas = 3.0;
  /// Lower bound of the MAD-sigma in metres: a flat face reads the same quantised depth in most
  /// pixels, making the MAD zero and the window empty but for that one value.
  double min_sigma_m = 0.01;
  /// Lower bound of the MAD-sigma in depth quantisation steps of `noise` at the median (the
  /// Kinect's step grows as z^2: 2.9 mm at 1 m, 2.6 cm at 3 m).
  double min_sigma_steps = 2.0;
  /// How often the median/MAD are recomputed over the kept readings (and the window re-applied
  /// to all readings); pulls the centre off a background that happened to sit near the median.
  int refine_iterations = 2;
  /// Clamp the faces to the kept readings' range (trimmed by range_trim at each end): beyond
  /// the nearest / farthest kept reading there is no evidence of the object, and a skewed kept
  /// set (object plus table behind it) would otherwise push the near face far in front of the
  /// object. With the default std_scale the clamp binds for most objects, so the faces sit at
  /// the 1st / 99th percentile of the kept readings; mean -/+ k * std binds for sparse sets.
  bool clamp_to_kept_range = true;
  /// Fraction of the kept readings ignored at each end for that clamp (single noisy pixels).
  double range_trim = 0.01;
  /// Readings beyond this are treated as missing (the seed's "infinite" cut-off).
  double max_valid_depth_m = 20.0;
  /// The near limit standing in for the seed's focal plane (see the file comment): no front
  /// corner ends up with z < min_front_depth_m. <= 0 disables the rule (z > 0 is still forced).
  double min_front_depth_m = 0.4;
  /// How far (pixels) the frustum reaches beyond the centres of the ROI's border pixels: 0.5 =
  /// the pixels' outer edges (the ROI's true footprint), 0 = the border pixel centres.
  double roi_pixel_margin = 0.5;
  /// Depth noise model used for `min_sigma_steps`.
  KinectNoiseModel noise{};
};

/// Depth statistics behind an estimate. In mode 1 the values are distances from the optical
/// centre (range_from_origin = true), otherwise Z depths; all in metres.
struct RoiDepthStatistics {
  int valid_pixels = 0;  ///< ROI pixels with a reading in (0, max_valid_depth_m]
  int used_pixels = 0;   ///< of those, kept by the robust window (mean/std/min/max are over these)
  double mean_m = 0.0;   ///< mean of the kept values
  double std_m = 0.0;    ///< population standard deviation of the kept values
  double median_m =
      0.0;  ///< robust centre of the final window (median of the kept set it was built on)
  double mad_sigma_m = 0.0;  ///< 1.4826 * MAD behind the final window, before the min-sigma floors
  double min_m = 0.0;        ///< nearest kept value
  double max_m = 0.0;        ///< farthest kept value
  double near_m = 0.0;  ///< front face distance used: mean - std_scale * std, clamped, after the
                        ///< near-limit rule
  double far_m =
      0.0;  ///< back face distance used: mean + std_scale * std, clamped, after the near-limit rule
  double moved_back_m = 0.0;       ///< shift applied by the near-limit rule (0 = not applied)
  bool range_from_origin = false;  ///< values are distances from the optical centre (mode 1)
};

/// Corner order: front (near) face first, then the back face, each as seen in the image:
/// top-left, top-right, bottom-right, bottom-left ("top" = smaller v / more negative y).
/// Index: 0 FTL, 1 FTR, 2 FBR, 3 FBL, 4 BTL, 5 BTR, 6 BBR, 7 BBL.
using BoxCorners = std::array<Eigen::Vector3d, 8>;

/// The 12 edges of a BoxCorners box as index pairs (front face, back face, connecting edges).
inline constexpr std::array<std::array<int, 2>, 12> kBoxEdges{{{0, 1},
                                                               {1, 2},
                                                               {2, 3},
                                                               {3, 0},
                                                               {4, 5},
                                                               {5, 6},
                                                               {6, 7},
                                                               {7, 4},
                                                               {0, 4},
                                                               {1, 5},
                                                               {2, 6},
                                                               {3, 7}}};

struct BoxEstimate {
  BoxCorners corners;  ///< camera frame, metres, order as documented at BoxCorners
  RoiDepthStatistics stats;
  BoxMode mode = BoxMode::kFrustumAligned;
  bool collapsed_x = false;  ///< mode 2: no box of that depth fits the ROI in x; x collapsed
  bool collapsed_y = false;  ///< mode 2: same for y
};

enum class BoxEstimationError {
  /// A corner lies outside the image (partly or wholly outside ROIs are not clipped: a clipped
  /// ROI no longer is the projection the caller meant).
  kRoiOutsideImage,
  /// The ROI has no pixels. Corners are inclusive, so a 1x1 ROI (p1 == p2) is valid and an
  /// in-image ROI is never empty: this is returned when the depth image itself has no pixels.
  kEmptyRoi,
  /// No pixel of the ROI has a depth reading (all zero or beyond max_valid_depth_m).
  kNoValidDepth,
  /// Not CV_16UC1, non-positive/non-finite focal lengths, intrinsics that put a corner of the
  /// ROI more than 88 degrees off the optical axis (no camera sees there; it would also make
  /// mode 1's range histogram unbounded), or an unknown BoxMode value.
  kInvalidArgument,
};

struct BoxEstimationFailure {
  BoxEstimationError code;
  std::string message;  ///< human-readable, for the caller to pass on
};

/// Estimates the box of the object seen in the ROI with corners p1, p2 (any two opposite
/// corners, inclusive pixel coordinates) of `depth_mm` (CV_16UC1 millimetres, 0 = no reading)
/// with the camera's `intrinsics`. Pure: no state kept between calls.
std::variant<BoxEstimate, BoxEstimationFailure> estimateBox(const cv::Mat& depth_mm,
                                                            const CameraIntrinsics& intrinsics,
                                                            cv::Point p1, cv::Point p2,
                                                            BoxMode mode = BoxMode::kFrustumAligned,
                                                            const BoxEstimationParams& params = {});

/// The checks every mode makes of a request: a CV_16UC1 image with pixels, positive finite
/// focal lengths, and the ROI with corners p1, p2 (inclusive, any two opposite corners) inside
/// the image. nullopt when the request is sound.
std::optional<BoxEstimationFailure> checkRoiRequest(const cv::Mat& depth_mm,
                                                    const CameraIntrinsics& intrinsics,
                                                    cv::Point p1, cv::Point p2);

/// Robust near/far statistics of the values (metres, > 0) using params' window; exposed so
/// callers and tests can inspect the statistic on their own samples. The values are counted in
/// 1 mm bins and every statistic is of the binned values: exact for millimetre depths (what
/// estimateBox's modes 2 and 3 see), within 0.5 mm otherwise (mode 1's ranges). near_m/far_m are
/// mean -/+ std_scale * std, clamped to the kept range (no near-limit rule). Requires a non-empty
/// input.
RoiDepthStatistics robustDepthStatistics(const std::vector<double>& values,
                                         const BoxEstimationParams& params = {});

/// Centre of a box given by corners in BoxCorners order: the mean of its eight corners.
inline Eigen::Vector3d boxCentre(const BoxCorners& corners) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& corner : corners) sum += corner;
  return sum / static_cast<double>(corners.size());
}

/// Volume (m^3) of a box given by corners in BoxCorners order (any hexahedron with planar
/// faces, e.g. the right prism of mode 1). 0 for collapsed boxes.
double boxVolume(const BoxCorners& corners);

/// Whether `point` lies inside the box (on the inner side of all six face planes, with
/// `tolerance_m` of slack). Works for the oriented boxes of mode 1 and for collapsed boxes.
bool boxContains(const BoxCorners& corners, const Eigen::Vector3d& point, double tolerance_m = 0.0);

/// Draws the box's 12 edges projected into `bgr` (CV_8UC3, same intrinsics). Edges crossing
/// behind the camera are clipped at z = 1 cm, edges wholly behind it are skipped, and lines are
/// clipped to the image, so any corners are safe to pass. The front face is drawn thicker.
void drawBox(cv::Mat& bgr, const CameraIntrinsics& intrinsics, const BoxCorners& corners,
             cv::Scalar color, int thickness = 2);

/// "FrustumAligned", "AxisAlignedContained", "AxisAlignedFrontFace", "Segments" or "Unknown".
const char* toString(BoxMode mode);
const char* toString(BoxEstimationError code);

}  // namespace shapesense
