#pragma once
// Depth image segmentation into regions (SRS "but_segmentation" design, D4.6.2 section 2.4).
//
// Four methods compute an edge-strength image E (small integer per pixel) and grow regions by
// immersion (a bucket-queue watershed ordered by E, first-in first-out within a level) from
// markers = connected components of low-edge areas:
//  - kDepthStep:       E = number of window neighbours whose depth differs by more than the
//                      range-dependent step threshold (occlusion / step edges),
//  - kNormalEdges:     E = number of window neighbours whose normal differs by more than an angle
//                      (roof edges); normals from NormalEstimator,
//  - kFused:           E = E_depth + weight * E_normal,
//  - kPlanePrediction: each neighbour's inverse depth is predicted from the centre's local
//                      inverse-depth gradient (planes are affine in inverse depth); E = number of
//                      anomalous neighbours in a dense window plus a sparse long-range ring (far
//                      creases bend inverse depth too little to show within a few pixels).
//                      Curved surfaces, anomalous at long range everywhere, keep markers from
//                      the dense window alone. No explicit normals.
// one is a plane segmenter:
//  - kTiledRansac:     a RANSAC plane per tile (in inverse-depth space, where Kinect noise is
//                      range-independent), tile planes merged across tile borders and flooded
//                      pixel by pixel so that tiles leave no seams; non-planar leftovers become
//                      regions of their own;
// and one combines the plane detector with them (the default, kDefaultSegmentationMethod):
//  - kPlanesAndObjects: each plane of the Hough plane detector (planes.h) is a region of its
//                      own; the pixels no plane covers take kPlanePrediction's regions, each
//                      connected piece apart (an object standing on a plane is cut from it by
//                      the plane, and from its neighbours by the prediction edges and by the
//                      plane between them); pixels still left (region borders,
//                      small pieces) join a depth-continuous neighbour. Then pieces of one
//                      surface are joined: an object region lying on a plane it borders (the
//                      rest of a face the plane detector found in part), curved pieces of one
//                      object that one quadric fits, and a flat region (a tin's top) lying
//                      mostly along a curved object. Given the frame's plane detection
//                      (segmentWithPlanes) it costs kPlanePrediction plus a few passes.
//
// All methods work at 1/`downsample` resolution (default 2, i.e. 320x240 for a Kinect frame) and
// upsample the labels with nearest neighbour; region borders are then accurate to 1-2 full-res
// pixels. Set downsample = 1 for full resolution (about 3-4x slower).
//
// Range-dependent thresholds follow KinectNoiseModel: a threshold of k "steps" is
// k * depthStep(z) in depth, i.e. k * disparity_step / focal_baseline in inverse depth.
//
// Output: CV_16UC1, 0 = unassigned (no depth, or a region below min_region_px), regions 1..N
// with compact ids, numbered in raster order of their first pixel.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/depth_step.h"
#include "shapesense/core/normals/normals.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

enum class SegmentationMethod {
  kDepthStep,
  kNormalEdges,
  kFused,
  kPlanePrediction,
  kTiledRansac,
  kPlanesAndObjects
};

/// Every method, in the order of the enum.
inline constexpr std::array<SegmentationMethod, 6> kSegmentationMethods = {
    SegmentationMethod::kDepthStep,   SegmentationMethod::kNormalEdges,
    SegmentationMethod::kFused,       SegmentationMethod::kPlanePrediction,
    SegmentationMethod::kTiledRansac, SegmentationMethod::kPlanesAndObjects};

/// The method the daemon, `shapesense analyze` and on-request queries use unless told otherwise.
/// planes_objects keeps planar faces apart and objects off their support and apart from each
/// other best of all the methods (docs/benchmarks.md, "Detection quality"); depth_step merges
/// an object standing on a table into the table.
inline constexpr SegmentationMethod kDefaultSegmentationMethod =
    SegmentationMethod::kPlanesAndObjects;

/// The one name of each method: "depth_step", "normal_edges", "fused", "plane_prediction",
/// "tiled_ransac" (command lines, requests and reports all use these).
std::string_view formatSegmentationMethod(SegmentationMethod method);
/// Inverse of formatSegmentationMethod; nullopt for an unknown name.
std::optional<SegmentationMethod> parseSegmentationMethod(std::string_view name);
/// The names of every method (kSegmentationMethods), for a command line's choices.
std::vector<std::string> segmentationMethodNames();
/// The names joined for a sentence: "depth_step, normal_edges, ..., plane_prediction" followed
/// by `last_separator` and the last name, e.g. " or tiled_ransac".
std::string listSegmentationMethods(std::string_view last_separator = " or ");

/// Region growing shared by every method (all sizes in full-resolution pixels).
struct RegionParams {
  /// Work at 1/downsample resolution (1 or 2; 2x2 blocks are averaged, see file comment).
  /// Default 2.
  int downsample = 2;
  /// Pixels with edge strength <= this seed the watershed markers. Default 0.
  int marker_max_edge = 0;
  /// Marker components smaller than this are dropped (their pixels are flooded). Default 64.
  int min_marker_px = 64;
  /// Final regions smaller than this are set to 0 (unassigned). Default 64.
  int min_region_px = 64;
  /// Merge regions that lie on one plane, even when they do not touch (a table split by the
  /// objects on it is one surface): regions are fitted with a plane in inverse depth (where Kinect
  /// noise is range-independent) and two are merged when the plane fitted to their union has an
  /// RMS residual <= coplanar_rms_steps quantisation steps. Greedy, best pair first. Default true.
  bool merge_coplanar = true;
  /// Default 2 steps (a synthetic plane measures ~0.3-0.5 steps RMS, a real Kinect table 1.2-1.5).
  double coplanar_rms_steps = 2.0;
  /// Only regions of at least this many full-resolution pixels take part. Default 200.
  int coplanar_min_px = 200;
  /// Sensor noise model for range-dependent thresholds. Default Kinect v1.
  KinectNoiseModel noise{};
};

/// The depth-step edge rule: how many window neighbours of a pixel lie across a depth step.
struct DepthStepEdgeParams {
  /// Window half-size (working-resolution pixels); E counts all (2r+1)^2-1 neighbours. Default 2.
  int window_radius = 2;
  /// Step threshold in sensor quantisation steps at the centre's range. Default 3.
  double noise_steps = 3.0;
  /// Plus this fraction of the range per full-resolution pixel of offset, so that steep but
  /// continuous surfaces (a floor seen at grazing angles) are not steps. Default 0.01.
  double slope_factor = 0.01;
  /// Never below this many millimetres. Default 10.
  double min_threshold_mm = 10.0;
};

/// kDepthStep: the depth-step edges and the region growing over them.
struct DepthStepParams : DepthStepEdgeParams {
  RegionParams region{};
};

/// The roof-edge rule: how many window neighbours of a pixel have a normal at a different angle.
struct NormalAngleEdgeParams {
  /// Window half-size (working-resolution pixels). Default 2.
  int window_radius = 2;
  /// Two normals differ when the angle between them exceeds this. Default 15 deg.
  double max_angle_deg = 15.0;
  /// Normal estimation at working resolution (smoothing radius is in working pixels).
  /// Default: average 3D gradient, radius 3 px at 1 m (less makes real Kinect tables noisy),
  /// windows down to 1 px next to steps.
  NormalParams normals = defaultNormals();

  static NormalParams defaultNormals() {
    NormalParams p;
    p.smoothing_radius_px = 3.0;
    p.min_radius_px = 1;
    p.max_radius_px = 10;
    return p;
  }
};

/// kNormalEdges: the roof edges and the region growing over them.
struct NormalEdgeParams : NormalAngleEdgeParams {
  RegionParams region{};
};

/// kFused: depth-step and roof edges added, and the region growing over their sum.
struct FusedParams {
  DepthStepEdgeParams depth{};
  NormalAngleEdgeParams normal{};
  /// E = E_depth + normal_weight * E_normal (the seed found 1 best). Default 1.
  double normal_weight = 1.0;
  /// Whether a pixel without a normal (normals are NaN within a few pixels of a depth step and on
  /// surfaces seen so obliquely that neighbours differ by more than the normal estimator's step
  /// threshold) counts as a normal edge. true (default): the NaN band also marks creases of
  /// obliquely seen faces, which the angle test alone finds only with gaps (synthetic scenes:
  /// pixel accuracy 0.70 with false, see tests). The depth term still contributes: it adds
  /// relief where the surface really steps, so the immersion flood puts region borders on the
  /// step instead of the middle of the NaN band, and it catches steps smaller than the normal
  /// estimator's threshold (max_depth_change_factor, 2% of range per pixel).
  bool invalid_normal_is_edge = true;
  RegionParams region{};
};

struct PlanePredictionParams {
  /// Half-size (working pixels) of the box filter smoothing inverse depth before the gradient.
  /// Default 2.
  int smoothing_radius = 2;
  /// Gradient = central difference of smoothed inverse depth over +-this many pixels. Default 2.
  int gradient_step = 2;
  /// Window half-size (working pixels) of the predicted neighbours. Default 3.
  int window_radius = 3;
  /// Also predict 16 neighbours at this distance (working pixels; the outer ring of a grid with
  /// spacing long_range / 2). A crease between two far surfaces bends inverse depth by only
  /// ~1 quantisation step per 2-3 pixels, below the noise within the dense window; farther
  /// neighbours see it. 0 disables. Default 6.
  int long_range = 6;
  /// Anomaly threshold of the long-range neighbours (quantisation steps). Default 3.
  double long_noise_steps = 3.0;
  /// Curved surfaces (bowls, balls) are anomalous at long range everywhere and would have no
  /// marker: a connected area without dense-window anomalies that holds no marker pixel becomes
  /// a marker of its own. Default true.
  bool curved_fallback_markers = true;
  /// A neighbour is anomalous when its inverse depth differs from the prediction by more than
  /// this many sensor quantisation steps (range-independent in inverse depth). Default 2.5.
  double noise_steps = 2.5;
  RegionParams region{};
};

struct TiledRansacParams {
  /// Tile size in working-resolution pixels. Default 16 (32 full-resolution pixels).
  int tile_size = 16;
  /// RANSAC hypotheses per tile. Default 24.
  int iterations = 24;
  /// Inlier threshold in sensor quantisation steps of inverse depth. Default 2.5.
  double inlier_noise_steps = 2.5;
  /// A tile plane is accepted when at least this fraction of its valid pixels are inliers.
  /// Default 0.6.
  double min_inlier_fraction = 0.6;
  /// Two neighbouring tile planes are merged when each explains at least this fraction of the
  /// other's inliers (checked on a sample). Default 0.8.
  double merge_fraction = 0.8;
  /// Seed of the deterministic RANSAC sampler. Default 1.
  std::uint32_t seed = 1;
  /// Depth-step edges that group the non-planar leftovers into regions. Default.
  DepthStepEdgeParams leftovers{};
  RegionParams region{};
};

struct PlanesAndObjectsParams {
  /// Passes in which pixels without a region join a neighbouring region on their surface.
  /// Default 4 (a region border of a few pixels).
  int grow_passes = 4;
  /// When two neighbouring readings lie on one surface. Default: 3 sensor steps or 1% of range.
  DepthStepRule continuity{3.0, 0.01};
  /// Object regions smaller than this (full-resolution pixels) are dissolved into their
  /// neighbours before the growth: slivers along creases and borders. Default 300 (0.1% of VGA,
  /// the plane detector's smallest region).
  int min_object_px = 300;
  /// ...and so are object regions with no pixel whose (2 r + 1)^2 window lies wholly inside
  /// them: strips along the creases between planes. Default 3 (7 x 7).
  int sliver_radius_px = 3;
  /// Regions smaller than this (full-resolution pixels) are dropped. Default 64.
  int min_region_px = 64;
  /// Whether an object region that is not curved and lies on a plane it borders joins it: the
  /// rest of a face the plane detector found only in part. It lies on the plane when the RMS
  /// distance of its points to it is within face_part_rms_steps sensor depth steps at its
  /// range, projected on the plane's normal (a grazing plane's points scatter off it by a
  /// fraction of their scatter in depth). Defaults true, 2 (1.5-2 alike on validation; a real
  /// Kinect table measures 1.2-1.5 steps RMS).
  bool join_face_parts = true;
  double face_part_rms_steps = 2.0;
  /// Whether curved objects that the steps above leave in pieces are joined again (below).
  /// Default true.
  bool join_curved_objects = true;
  /// An object region is curved when a quadric fits its points (every
  /// curved_sample_step_px pixels) curved_rms_ratio times better than their plane and bends
  /// more than curved_min_curvature_per_m. Defaults 2 px, 2, 2 /m (a radius of 0.5 m). Faces
  /// meeting at a crease (a table leg's two sides in one region) reach ratios up to ~1.7.
  int curved_sample_step_px = 2;
  double curved_rms_ratio = 2.0;
  double curved_min_curvature_per_m = 2.0;
  /// ...or when it is no plane (its plane's RMS residual is at least
  /// curved_surface_min_plane_rms_steps sensor depth steps at its range) but lies on one quadric
  /// surface: the RMS of its points' distances to an implicit quadric (quadric_surface.h) is at
  /// most 1 / curved_surface_rms_ratio of its plane's, and at most
  /// 1 / curved_surface_two_plane_ratio of that of two planes fitted to it (two faces at a
  /// crease are a quadric too). That holds a bowl's whole outside or a bin seen across half its
  /// girth, of which the height-field quadric above fits only a cap. A region needs at least 60
  /// samples for the two-plane fit, and a plane RMS above crease_face_rms_steps. Defaults 2
  /// steps, 3 (2-6 alike on validation), 2 (1.5-2 alike; 1.2 merges more).
  double curved_surface_min_plane_rms_steps = 2.0;
  double curved_surface_rms_ratio = 3.0;
  double curved_surface_two_plane_ratio = 2.0;
  /// Two curved object regions are one object when at least join_min_border_px pixel
  /// pairs across their border, and join_min_continuous_share of all, have no depth step
  /// between them. Defaults 10, 0.7.
  int join_min_border_px = 10;
  double join_min_continuous_share = 0.7;
  /// ...and one quadric fits both with an RMS residual at most join_quadric_rms_factor times
  /// that of their own two quadrics, or one implicit quadric surface fits both with an RMS
  /// distance at most join_surface_rms_factor times that of their own two surfaces (or than half
  /// a depth step, which their own may fit below). Defaults 2 and 1.2 (1.1-2 alike on validation
  /// and mosd_learn; two real objects standing side by side fit one surface 1.6-2 times worse
  /// than their own).
  double join_quadric_rms_factor = 2.0;
  double join_surface_rms_factor = 1.2;
  /// A region that is not curved (a tin's flat top, a piece of a bowl) joins a curved object
  /// when at least this share of its border pixel pairs without a depth step lie along that
  /// object. 0 disables. Default 0.8.
  double cap_min_border_share = 0.8;
  /// Whether an object region left whole by the joining that is two faces meeting at a crease
  /// is split into them: its one plane fits it worse than 2 x crease_face_rms_steps sensor
  /// depth steps RMS, and two planes each fit their points within crease_face_rms_steps, with
  /// normals crease_min_angle_deg or more apart. Defaults true, 1 step, 20 deg.
  bool split_creased_objects = true;
  double crease_face_rms_steps = 1.0;
  double crease_min_angle_deg = 20.0;
  /// The planes when segmentDepth detects them itself (segmentWithPlanes takes them given).
  HoughPlaneParams planes{};
};

struct SegmentationParams {
  DepthStepParams depth_step{};
  NormalEdgeParams normal_edges{};
  FusedParams fused{};
  PlanePredictionParams plane_prediction{};
  TiledRansacParams tiled_ransac{};
  /// kPlanesAndObjects; its object regions use plane_prediction above.
  PlanesAndObjectsParams planes_and_objects{};
};

/// Segments a CV_16UC1 millimetre depth image; returns CV_16UC1 regions (0 = unassigned,
/// 1..N compact).
cv::Mat segmentDepth(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                     SegmentationMethod method, const SegmentationParams& params = {});

/// kPlanesAndObjects with the frame's plane detection already made (`planes`, of this depth
/// image): what the pipeline calls after its plane stage. Any other method ignores `planes`.
cv::Mat segmentWithPlanes(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                          SegmentationMethod method, const PlaneDetection& planes,
                          const SegmentationParams& params = {});

/// The edge-strength image a watershed method floods (CV_8UC1 at working resolution, 255 where
/// there is no depth); for inspection and tests. Not defined for kTiledRansac (returns empty);
/// kPlanesAndObjects returns kPlanePrediction's.
cv::Mat segmentationEdgeStrength(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                 SegmentationMethod method, const SegmentationParams& params = {});

}  // namespace shapesense
