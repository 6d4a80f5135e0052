#pragma once
// 3D verification of a bowl detection: is the depth behind the detector's box bowl-shaped at a
// bowl's size, standing on a supporting surface?
//
// The WaldBoost/LBP classifier (bowl_detector.h) sees an 8-bit depth texture and is fooled by
// round things of any shape: tins seen from the side, upside-down bowls, parts of furniture in
// a room. Metric depth separates them. The check, in one pass over the box:
//   1. the support: of the detected planes that face up, show beside and below the box and
//      hold the object above them, the one that shows most there;
//   2. the object: the connected surface above that plane that holds the box's centre
//      (connectivity broken at depth steps, so neighbours and the background fall away);
//   3. its profile in the support's frame: height above the plane, and the width across the
//      line of sight of the points near the top (the rim) and near the bottom (the foot).
// A bowl is wider at its rim than at its foot (looking in from above, the bottom band is the
// small inside bottom; from the side, the outer wall narrows to the foot), and it is dished:
// the middle, near its axis, lies well below its rim (the inside bottom looking in, the foot
// of the front wall from the side). Far away, where the sensor's depth steps cut off the lower
// part, the dish still shows when the width profile no longer does; either cue suffices. A
// tin, a box or a ball keeps its width (or is widest in the middle) and has its top in the
// middle; an upside-down bowl is widest at the table and highest in the middle. The rim width
// must fall in [min, max]_rim_diameter_m and the height must suit a bowl of that rim.
//
// Usage:
//   auto planes = hough_detector.detect(depth_mm, intrinsics);
//   auto result = measureBowlGeometry(depth_mm, intrinsics, detection.box, planes);
//   if (result.isBowl()) ... result.geometry.rim_diameter_m ...

#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

/// Parameters of measureBowlGeometry. The size limits describe what counts as a bowl; the
/// rest are chosen on the synthetic validation split and the real learn frames
/// (models/README.md).
struct BowlGeometryParams {
  double min_rim_diameter_m = 0.08;  ///< smallest rim accepted (m). Default 8 cm.
  double max_rim_diameter_m = 0.35;  ///< largest rim accepted (m). Default 35 cm.
  /// Height over rim diameter: the object's top must rise above its support by at least the
  /// minimum (a plate or a lid does not), and its own visible extent, lowest to highest point,
  /// must stay within the maximum (a vase does not; a bowl standing on another object still
  /// does). A hemisphere is 0.5, a shallow dish 0.2. Defaults 0.15 and 0.8.
  double min_height_to_diameter = 0.15;
  double max_height_to_diameter = 0.8;
  /// The rim band's width over the foot band's width must reach this. Default 1.2: a
  /// hemisphere gives ~1.5 and a shallow cap ~1.9, a cylinder or box ~1.0.
  double min_rim_to_foot_width = 1.2;
  /// ...or the middle of the object, near its axis, must lie below its top by this share of
  /// its height (a bowl's inside bottom looking in, its front wall's foot from the side; a
  /// tin's lid or an upside-down bowl's crown is at the top). Default 0.4.
  double min_dish_depth = 0.4;
  /// "Near the axis": within this share of the rim diameter. Default 0.3.
  double dish_radius_fraction = 0.3;
  /// Share of the object's height (from its lowest to its highest point) that forms the foot
  /// band at the bottom and the rim band at the top. Default 0.3.
  double band_fraction = 0.3;
  /// A reading belongs to the object when it lies above the support by more than
  /// clearance_steps depth steps of the sensor at its range and at least min_clearance_m.
  /// Defaults 2 steps (5 mm at 1.4 m, 1.2 cm at 2 m, 2.6 cm at 3 m) and 1 cm: enough to leave
  /// the support's own noise out, little enough to keep most of a small bowl far away.
  double clearance_steps = 2.0;
  double min_clearance_m = 0.01;
  /// An object whose top stands fewer than this many depth steps of the sensor above its
  /// support at its range is too coarsely seen to be judged (a bowl 5 cm tall at 3.5 m spans
  /// under two steps): inconclusive. Default 3 (a 5 cm bowl is measured up to ~2.4 m).
  double min_top_steps = 3.0;
  KinectNoiseModel noise{};  ///< the sensor's depth steps. Default Kinect v1.
  /// Two neighbouring pixels are one surface when their depths differ by at most this many
  /// depth steps (and at least max_step_floor_m). Defaults 4 steps, 1 cm.
  double max_step_steps = 4.0;
  double max_step_floor_m = 0.01;
  /// The box is read on a grid of every s-th pixel, s the smallest step that leaves at most
  /// this many samples (0: every pixel); samples s pixels apart are one surface within s times
  /// the step limit above. The measures are quantiles and band widths, which a few thousand
  /// samples settle as well as every pixel does, at a fraction of the time.
  int max_box_samples = 2000;
  /// A plane is a support candidate when at least this many of the ~1200 grid samples of the
  /// support window carry its label. Default 12 (1%).
  int min_support_samples = 12;
  /// A support faces up in the image: its normal lies within this angle (degrees) of the
  /// camera's up axis (-y), as a table or floor does for a camera held upright (roll within
  /// +-15 deg) and pitched down by up to ~70 deg. Walls and vertical box faces, which a bowl can
  /// stand in front of but not on, fall outside. Default 75.
  double max_support_angle_from_image_up_deg = 75.0;
};

/// A bowl's measured geometry.
struct BowlGeometry {
  double rim_diameter_m = 0;     ///< width of the rim band across the line of sight
  double height_m = 0;           ///< from the object's lowest to its highest visible point
  double top_m = 0;              ///< its highest point above the support
  double rim_to_foot_width = 0;  ///< rim band width over foot band width
  double dish_depth = 0;  ///< depth of the middle below the top, share of the height (-1: none)
  /// The support plane n.X + d = 0 (n towards the camera, so heights above it are positive).
  Eigen::Vector3d support_normal = Eigen::Vector3d::Zero();
  double support_d = 0;
  /// Id of the support in the PlaneDetection (DetectedPlane::id).
  std::uint16_t support_plane_id = 0;
};

/// Why a box is not bowl-shaped.
enum class BowlGeometryRejection {
  kNoSupport,      ///< no detected plane under the box
  kNoObject,       ///< nothing stands on the support at the box's centre
  kTooCoarse,      ///< the object spans fewer than min_top_steps depth steps at its range
  kRimTooSmall,    ///< rim band narrower than min_rim_diameter_m (or only part of it seen)
  kRimTooLarge,    ///< rim band wider than max_rim_diameter_m
  kHeight,         ///< height out of proportion to the rim
  kNotBowlShaped,  ///< neither wider at the rim than at the foot nor dished
};

/// A short English reason ("no supporting plane under the box", ...).
std::string toString(BowlGeometryRejection reason);

/// Whether the depth only failed to show the bowl (no support in view, nothing measurable
/// standing at the box's centre, an object too far for the sensor's depth steps, a rim seen in
/// part) rather than showing something else.
bool isInconclusive(BowlGeometryRejection reason);

/// What measureBowlGeometry found.
struct BowlGeometryResult {
  /// Why the box is not a bowl; empty when it is one.
  std::optional<BowlGeometryRejection> rejection;
  /// The measurements; on a rejection those taken before it (the rest stay 0).
  BowlGeometry geometry;
  bool isBowl() const { return !rejection.has_value(); }
};

/// Measures the object behind `box` (pixels of depth_mm, clipped to the image) standing on
/// one of `planes`, the plane detection of the same frame.
BowlGeometryResult measureBowlGeometry(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                       const cv::Rect& box, const PlaneDetection& planes,
                                       const BowlGeometryParams& params = {});

}  // namespace shapesense
