#pragma once
// Plane detection in Kinect depth images: the Hough detector of SRS D4.6.2 section 2.2
// (issue 4). Related headers: hough_accumulator.h (the sparse hierarchical space),
// plane_fitting.h (least squares, noise tolerance), plane_labeling.h (samples -> full-resolution
// label image, connected regions), plane_polygon.h (boundary polygons), plane_ransac.h (the
// RANSAC baseline), plane_accumulator.h (accumulation over time).
//
// Pipeline of HoughPlaneDetector::detect:
//  1. Samples: every `sample_step`-th pixel of each `sample_step`-th row; normals from the shared
//     NormalEstimator run on that subsampled depth image (its windows then span
//     sample_step x more pixels of the original, which is what the noise needs anyway).
//  2. Votes: each sample whose normal agrees with its 4 grid neighbours within
//     `vote_max_normal_spread_deg` (a planarity test: curved surfaces and creases do not vote)
//     votes once for (n, d = -n.X). Votes are counted, then smoothed (Gaussian, sigmas in degrees
//     and metres), maxima are found with a sliding window.
//  3. Refinement: strongest maximum first, samples within PlaneTolerance of the plane whose
//     normal is within `inlier_max_normal_deg` are fitted by least squares (shrinking gates,
//     `refine_iterations` times); accepted planes take their samples. Unclaimed samples vote
//     again in the next round (`rounds`), which finds planes hidden next to bigger parallel ones
//     (a box top 5 cm above the table shares the table's smoothed peak).
//  4. Near-duplicate planes are merged (angle and distance gates), and a plane whose samples lie
//     on two faces at a crease is split in two (two_face_gain). Depth-continuous components of
//     samples no plane took (thin strips, small faces without reliable normals) are fitted by
//     least squares (as two faces, likewise), or split by sequential RANSAC when they hold
//     several faces.
//  5. Labelling (plane_labeling.h): region growing on the sample grid, connected regions (a
//     region = one physical surface: two box tops at the same height get two ids), every
//     full-resolution pixel takes the closest plane among the regions of its neighbouring
//     samples within that plane's tolerance (tightened from the plane's own residuals), each
//     region is refitted on its full-resolution pixels, and adjacent coplanar regions merge;
//     the strips a plane took across a crease of a surface not found as a plane are given back
//     (PlaneLabelingParams::crease_*); regions that bend are dropped (curved surfaces), and a
//     region on two faces, at a crease or apart, gives back the smaller (minor_face_*).
//
// Output: one DetectedPlane per connected region; `group` tells which regions share a
// supporting plane. See DetectedPlane.

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/normals/normals.h"
#include "shapesense/core/planes/hough_accumulator.h"

namespace shapesense {

/// One detected planar region.
struct DetectedPlane {
  std::uint16_t id = 0;  ///< value of this region in PlaneDetection::labels (1, 2, ...)
  /// Index of the supporting plane found by the detector; regions with the same group lie on one
  /// detected plane (e.g. two box tops at the same height) but are separate surfaces.
  int group = 0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, towards the camera
  double d = 0.0;                                    ///< n.X + d = 0, d > 0 (metres)
  std::size_t inliers = 0;                           ///< full-resolution pixels labelled `id`
  double rms_m = 0.0;  ///< RMS orthogonal distance of the inliers to the plane
  cv::Rect box;        ///< image bounds of the inliers
  /// Boundary of the region on the plane (camera frame, metres): the outer contour of the
  /// label region (a concave hull), simplified, with its vertices cast onto the plane.
  std::vector<Eigen::Vector3d> polygon;
  /// Triangulation of `polygon` (indices into it) for display.
  std::vector<std::array<int, 3>> triangles;
  std::optional<cv::Vec3b> mean_bgr;  ///< mean colour of the inliers when BGR was given
};

struct PlaneDetection {
  std::vector<DetectedPlane> planes;  ///< ordered by id
  cv::Mat labels;                     ///< CV_16UC1, 0 = no plane, k = DetectedPlane::id
};

/// Sampling, labelling and output options shared by the Hough and RANSAC detectors.
struct PlaneLabelingParams {
  /// Sample grid step (pixels). Votes, fits and region growing run on every step-th pixel;
  /// the final label image and the per-region fits use every pixel. Default 4 (19 200 samples
  /// on VGA; a 0.5%-of-image box face still has ~95).
  int sample_step = 4;
  /// Inlier tolerance (orthogonal distance) as a function of range. Default 3 steps, >= 4 mm.
  PlaneTolerance tolerance{};
  /// Regions smaller than this many full-resolution pixels are dropped. Default 300 (0.1% of VGA).
  int min_region_pixels = 300;
  /// Region growing does not take samples with a reliable normal further off the plane than
  /// this (see growSampleLabels). Default 15 deg.
  double grow_max_normal_deg = 15.0;
  /// ...nor samples whose normal is valid but unreliable (blurred by an edge) further off than
  /// this: without it a plane grows over a narrow perpendicular strip (a table's front edge)
  /// whenever the strip's depth stays within the range-dependent tolerance. Default 45 deg
  /// (the blurred samples right at the fold are ~45 deg off either surface).
  double grow_max_unreliable_normal_deg = 45.0;
  /// Per-plane inlier tolerance for region growing and pixel labelling: this factor times the
  /// RMS residual (in sensor depth steps) of the plane's samples, clamped to
  /// [min_tolerance_steps, tolerance.noise_steps]. Clean planes get a tighter band, so a plane
  /// stops claiming the first centimetres of every surface that meets it (a table top the
  /// front edge, a leg front the leg side) where the fixed tolerance is several cm at range.
  /// 0 = always the fixed tolerance. Defaults 3 and 1.5 steps.
  double adaptive_tolerance_factor = 3.0;
  double min_tolerance_steps = 1.5;
  /// Split planes into connected regions (one id per physical surface, SegComp-style). Default
  /// true.
  bool split_connected_regions = true;
  /// ...but re-join pieces of one plane that are separated only by occluders, holes or the
  /// plane itself (floor between table legs): one id per physical surface. Default true.
  bool merge_occluded_pieces = true;
  /// Merge adjacent, depth-continuous regions whose full-resolution fits are within
  /// merge_coplanar_max_angle_deg and whose joint fit has RMS <= max(merge_coplanar_rms_factor
  /// x the worse of the two, tolerance / 3): one surface found as two pieces of two nearly
  /// identical hypotheses. Defaults true, 10 deg, 1.3.
  bool merge_coplanar_regions = true;
  double merge_coplanar_max_angle_deg = 10.0;
  double merge_coplanar_rms_factor = 1.3;
  /// A region is a plane only if a quadric does not fit its samples markedly better: a region
  /// whose quadric fit has a principal curvature above max_plane_curvature_per_m (a radius
  /// under 1 / that) and whose plane RMS is at least curved_rms_ratio times the quadric's is
  /// dropped (the sides of tins, balls and bowls). Sensor noise and quantisation do not bend,
  /// so a flat surface passes at any range. The check runs after the crease step: a strip of
  /// the surface beyond a crease would bend a flat face's quadric too. 0 = no check. Defaults
  /// 2 /m (50 cm radius) and 1.1 (chosen on the validation split, docs/benchmarks.md).
  double max_plane_curvature_per_m = 2.0;
  double curved_rms_ratio = 1.1;
  /// Two adjacent regions whose normals differ by at most curved_pair_max_angle_deg are two
  /// facets of one curved surface (a bin or a column found as several planes), and both are
  /// dropped, when each bends so on its own and one quadric with such a curvature fits their
  /// samples together with an RMS of at most curved_pair_rms_factor times that of their two
  /// plane fits (pooled). A crease or a
  /// step between two planes is no quadric, so they stay. 0 = no pair check. Defaults 1.0 and
  /// 60 deg.
  double curved_pair_rms_factor = 1.0;
  double curved_pair_max_angle_deg = 60.0;
  /// Strips a plane takes across a crease, where the surface beyond it was not found as a
  /// plane of its own, are given back (see the labelling's crease step): from a region's
  /// boundary inwards, a pixel goes when the readings within crease_window_px of it (those
  /// within reach of the plane) have a mean residual beyond crease_mean_sigmas of the plane's
  /// noise and crease_min_outside_share of them lie beyond crease_outside_sigmas on that side,
  /// for at most crease_max_passes pixels inwards (0 = no peeling). The plane's noise is the
  /// RMS residual of its samples, in depth steps, so it scales with range. Defaults 3 px, 0.7,
  /// 1.4, 0.15 and 6 (chosen on the validation split, docs/benchmarks.md). Without peeling, a
  /// face that keeps a strip bends like a curved surface: curved_rms_ratio 1.3 then keeps more
  /// of them (and more spurious planes).
  int crease_window_px = 3;
  double crease_mean_sigmas = 0.7;
  double crease_outside_sigmas = 1.4;
  double crease_min_outside_share = 0.15;
  int crease_max_passes = 6;
  /// After the curvature check, a region that is two faces gives back the pixels of the
  /// smaller: two planes fit its pixels minor_face_gain times better than one, by RMS distance,
  /// each holds 15% of them, and they meet at a crease (at least minor_face_min_angle_deg apart)
  /// or the smaller's centre lies minor_face_min_gap_steps sensor depth steps or more off the
  /// larger (a gap the sensor resolves: a book on a table, two touching boxes' fronts). Far off,
  /// both faces lie within the tolerance of one plane between them, which then fits neither.
  /// Not before the curvature check: a curved surface cut down to one of its "faces" would pass
  /// it. 0 = never. Defaults 1.6, 30 deg and 2.5 steps (1.4-2.0, 30-60 deg and 1-4 steps tried
  /// on the validation split, docs/benchmarks.md).
  double minor_face_gain = 1.6;
  double minor_face_min_angle_deg = 30.0;
  double minor_face_min_gap_steps = 2.5;
  /// After the crease step, pixels with depth that no plane took and that lie on the surface of
  /// a plane beside them (within its tolerance, no depth step on the way) join it, ring by ring
  /// from its border: the patches of a face whose samples carried normals too far off for the
  /// sample growth. Pixels the crease step gave back are not taken again. Default true.
  bool grow_into_unreached_pixels = true;
  /// Compute polygon and triangles. Default true.
  bool compute_polygons = true;
  /// Polygon simplification tolerance in sample-grid cells (Douglas-Peucker). Default 1.
  double polygon_epsilon_cells = 1.0;
};

struct HoughPlaneParams {
  /// The labelling defaults, with the inlier tolerance at 2.5 sensor depth steps instead of 3:
  /// a tighter band leaves more small faces beside a larger plane their own, but cuts curved
  /// surfaces into strips too narrow to show their curvature. 2.5 is the tightest that left
  /// the planes found on curved surfaces where they were on the validation split.
  PlaneLabelingParams labeling{.tolerance = {.noise_steps = 2.5}};
  /// Normal estimation on the sample grid. Defaults (see defaultSampleNormalParams): 3D
  /// gradient, 2-sample half-window at 1 m (8 px at step 4), 1..5 samples, the depth-step rule
  /// never tighter than 4 times the frame's measured noise.
  NormalParams normals = defaultSampleNormalParams(4);
  /// Resolution of the per-frame Hough space. Default 1.5 deg x 2 cm.
  HoughSpaceParams space{};
  /// Smoothing kernel sigmas. The vote spread of one Kinect plane is the normal noise (~1-2 deg
  /// at 0.5-3 m with the sample windows) in angle, and in d the depth noise (0.5 mm at 0.5 m to
  /// 3.7 cm at 4.5 m) plus range x normal noise (2-8 cm at 2-4.5 m); sigma_d 3 cm with its
  /// 2.5-sigma truncation covers that to 4.5 m; closer planes are sharper than the kernel, which
  /// only costs resolution (the refinement restores it). Defaults 2 deg, 0.03 m.
  double sigma_angle_deg = 2.0;
  double sigma_d_m = 0.03;
  /// Sliding window half-size (cells) of the maxima search, >= 0 (a negative value counts as
  /// 0: no neighbours compared along that axis). Default 2 (+-3 deg, +-4 cm).
  int maxima_window_a = 2;
  int maxima_window_d = 2;
  /// A sample votes only if its 4 grid neighbours have normals within this angle. Default 3
  /// deg: the bend between neighbouring samples of a tin or a column stays out of the vote, and
  /// the real frames' flat surfaces still vote (chosen on the validation split and mosd_learn;
  /// 1.5 deg kept 38 of 42 real objects apart on mosd_tabletop, against 40).
  double vote_max_normal_spread_deg = 3.0;
  /// Normal gate of refinement inliers. Default 12 deg (sample normals near edges are blurred;
  /// the distance gate does most of the work).
  double inlier_max_normal_deg = 12.0;
  /// Least-squares refinement iterations per candidate. Default 4.
  int refine_iterations = 4;
  /// Minimum samples for a plane (votes and refined inliers). Default 18 (~290 px at step 4).
  int min_plane_samples = 18;
  /// Vote / refine / remove rounds. Default 3.
  int rounds = 3;
  /// Candidate maxima tried per round. Default 40.
  int max_candidates_per_round = 40;
  /// Merging of near-duplicate planes (see step 5 in the .cpp): candidates within this angle
  /// (default 15 deg: thin strips fitted in pieces disagree by several degrees)...
  double merge_angle_deg = 15.0;
  /// ...merge when the RMS of their joint fit is <= max(merge_rms_factor x the worse RMS,
  /// merge_tolerance_factor x tolerance / 3 at their range). Defaults 1.3 and 1.0.
  double merge_rms_factor = 1.3;
  double merge_tolerance_factor = 1.0;
  /// A plane, voted for or fitted to a leftover component, whose samples two planes fit
  /// two_face_gain times better (RMS distance), each with twice min_plane_samples, is two faces,
  /// each a plane: far off, both faces of a table leg or a box edge lie within the tolerance of
  /// one plane through their crease. Default 2 (1.5-3 tried on the validation split,
  /// docs/benchmarks.md); 0 = never.
  double two_face_gain = 2.0;
  /// Fit depth-continuous components of samples left unassigned by the Hough stage (thin and
  /// small surfaces without reliable normals, see the pipeline step 6 comment). Default true.
  bool fit_leftover_components = true;
  /// ...accepting a component when this fraction of its samples fits one plane (two planes when
  /// it is two faces, see two_face_gain). Default 0.8.
  double leftover_min_inlier_fraction = 0.8;
  /// Components that are not one plane are split by sequential RANSAC with this many
  /// hypotheses per extracted plane (0 = off). Default 64.
  int leftover_ransac_hypotheses = 64;
  /// ...keeping a RANSAC plane only when leftover_min_inlier_fraction of its inliers agree with
  /// it within this angle, each inlier's normal fitted to the inliers within 2 samples of it
  /// (the sample grid's normals are blurred across the creases of a thin face; the inliers' own
  /// normals still fan out on a band of a curved surface or across the faces of a small box
  /// corner). Default 15 deg.
  double leftover_normal_agreement_deg = 15.0;

  /// NormalParams suited to a grid subsampled by `step` (windows and gaps in grid cells).
  static NormalParams defaultSampleNormalParams(int step);
};

/// Reusable Hough plane detector; keeps its buffers (normals, Hough spaces) between frames.
class HoughPlaneDetector {
 public:
  explicit HoughPlaneDetector(HoughPlaneParams params = {});
  ~HoughPlaneDetector();
  HoughPlaneDetector(HoughPlaneDetector&&) noexcept;
  HoughPlaneDetector& operator=(HoughPlaneDetector&&) noexcept;

  const HoughPlaneParams& params() const { return params_; }

  /// depth_mm: CV_16UC1 millimetres (0 = none). bgr: optional CV_8UC3 registered colour.
  PlaneDetection detect(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                        const cv::Mat& bgr = {});

  /// The smoothed Hough space of the last round of the last frame (for inspection / tests),
  /// evaluated only around the cells that can reach the peak threshold (zero elsewhere). The
  /// cells around every peak are exact; farther blocks whose neighbourhood mass lies within
  /// float rounding of the pruning threshold may be evaluated or zero depending on the order
  /// the masses are summed in (the detected planes never depend on it).
  const HoughAccumulator& lastSmoothedSpace() const;

 private:
  struct Impl;
  HoughPlaneParams params_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shapesense
