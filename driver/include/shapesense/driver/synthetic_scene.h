#pragma once
// Procedural table-top scenes rendered as a Kinect v1 sees them, with exact ground truth.
//
// This is the project's test-fixture factory: every detector is tested against the truth that
// comes with each frame, so the renderer is physically faithful where detectors care (exact
// analytic geometry, the Kinect disparity noise and quantisation, projector shadows, grazing
// dropouts, range limits) and deliberately simple elsewhere (no multipath, no edge blur, no
// registration offset between colour and depth).
//
// World frame (used only for the pose): z up, floor at z = 0, metres. Everything in a
// TruthFrame is expressed in the camera frame of that frame (OpenCV: x right, y down,
// z forward), except `world_from_camera` itself.
//
// Determinism: a scene is a pure function of SceneParams; frame i is a pure function of
// (params, i). Noise is drawn from a generator seeded by (seed, i), so render(i) gives the same
// bytes whatever was rendered before, on any thread (render is const and thread-safe).
//
// Scene content (ranges are the defaults of SceneParams):
//  - room: floor, ceiling and four walls ("floor", "ceiling", "wall_back", "wall_left",
//    "wall_right", "wall_front" - the last is behind the camera). Object id 0.
//  - a table (object kind "table"): a top slab on four legs. Surfaces "table_top",
//    "table_underside", "table_edge_{front,back,left,right}" and
//    "table_leg<k>_face_{front,back,left,right,bottom,top}".
//  - boxes (kind "box"), yawed, on the table and sometimes one on the floor. Each face is a
//    surface "box<k>_face_{top,bottom,front,back,left,right}" (front = the box's local -y).
//  - bowls (kind "bowl"): spherical-cap shells (from a shallow cap to a hemisphere) with a
//    shell thickness, rim radius 6-15 cm, upright (optionally upside down). Surfaces
//    "bowl<k>_outer" and "bowl<k>_inner" (curved) and "bowl<k>_rim" (the flat annulus).
//  - cups (kind "cup"): open cylinders with a wall thickness and a bottom. Surfaces
//    "cup<k>_outer", "cup<k>_inner" (curved), "cup<k>_rim" and "cup<k>_inner_bottom" (planes).
//  - tins (kind "tin"): closed cylinders. Surfaces "tin<k>_side" (curved), "tin<k>_top",
//    "tin<k>_bottom" (planes).
//  - balls (kind "ball"): spheres, surface "ball<k>" (curved).
// Every object rests on the table top or the floor and no two objects interpenetrate
// (footprint circles are kept apart). Object counts are drawn uniformly within the ranges;
// an object that finds no free spot after many tries is left out, so a crowded table can hold
// fewer objects than drawn.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/frame.h"

namespace shapesense::synthetic {

/// The Kinect v1 depth sensor model applied to the ideal (ray-cast) depth.
///
/// Per pixel: disparity = focal_baseline / z, plus Gaussian noise, quantised to
/// disparity_step, converted back to z and rounded to whole millimetres. Pixels get no
/// depth (0) when the point is in the projector's shadow, when the incidence angle exceeds
/// max_incidence_deg, at random (dropout_rate), or when the ideal or the measured z is outside
/// [min_range, max_range]. Shadows are exact for occluders seen by the camera or up to
/// f*b/min_range pixels right of the image; the disparity model uses focal_baseline_px_m while
/// the shadow geometry uses projector_baseline_m (the Kinect's nominal values disagree a bit).
/// Noise is independent per pixel and per frame (no 9x9 correlation window, no edge blur).
struct KinectParams {
  double focal_baseline_px_m = 43.5;    ///< f * b of the disparity model (px * m). Default 43.5.
  double projector_baseline_m = 0.075;  ///< IR projector offset along camera +x (m). Default 0.075.
  double disparity_noise_px = 0.07;  ///< sigma of the Gaussian disparity noise (px). Default 0.07.
  double disparity_step_px = 0.125;  ///< disparity quantisation (px). Default 1/8.
  double min_range_m = 0.5;          ///< nearer readings are dropped. Default 0.5.
  double max_range_m = 4.5;          ///< farther readings are dropped. Default 4.5.
  double dropout_rate = 0.002;       ///< probability a valid pixel reads 0 anyway. Default 0.002.
  double max_incidence_deg = 80.0;   ///< steeper incidence (ray vs normal) reads 0. Default 80.
  bool projector_shadows = true;     ///< drop pixels the projector cannot see. Default true.
};

/// Everything that defines a scene. Two equal SceneParams give byte-identical frames.
struct SceneParams {
  std::uint64_t seed = 1;       ///< layout, colours and per-frame noise. Default 1.
  CameraIntrinsics intrinsics;  ///< of the depth (and registered colour) image. Kinect v1.
  KinectParams kinect;          ///< sensor noise model, see KinectParams.

  /// Scale of the slow camera sway: 1 = a few cm and ~1-1.5 degrees over seconds, 0 = static.
  double camera_motion = 1.0;
  /// Converts frame index to scene time for the sway (frame i is at i / frame_rate_hz s).
  /// Default 30. SyntheticSource and writeSyntheticRecording set it to their fps.
  double frame_rate_hz = 30.0;

  /// Camera (robot head) height above the floor, drawn uniformly (m). Default 0.8-1.4.
  double camera_height_min_m = 0.8;
  double camera_height_max_m = 1.4;
  /// Distance from the camera to the centre of the table top, drawn uniformly (m); the upper
  /// end is lowered when needed to keep the view elevation. Default 0.8-2.5.
  double table_distance_min_m = 0.8;
  double table_distance_max_m = 2.5;
  /// Minimum angle at which the camera looks down on the table-top centre (deg). Default 12.
  double min_table_elevation_deg = 12.0;

  int boxes_on_table_min = 2;                 ///< Default 2.
  int boxes_on_table_max = 4;                 ///< Default 4.
  double floor_box_probability = 0.5;         ///< chance of one more box on the floor. Default 0.5.
  int bowls_min = 1;                          ///< Default 1.
  int bowls_max = 3;                          ///< Default 3.
  double bowl_upside_down_probability = 0.0;  ///< Default 0 (all bowls upright).
  int cups_min = 0;                           ///< Default 0.
  int cups_max = 2;                           ///< Default 2.
  int tins_min = 0;                           ///< Default 0.
  int tins_max = 2;                           ///< Default 2.
  int balls_min = 0;                          ///< Default 0.
  int balls_max = 2;                          ///< Default 2.

  bool render_colour = true;  ///< false leaves Frame::rgb empty (saves ~25% time). Default true.
};

enum class SurfaceKind { kPlane, kCurved };

/// One surface of the scene as seen in one frame.
struct TruthSurface {
  std::uint16_t id = 0;  ///< the value in TruthFrame::surface_labels (never 0)
  std::string name;      ///< e.g. "floor", "table_top", "box2_face_top", "bowl1_inner"
  SurfaceKind kind = SurfaceKind::kPlane;
  /// kPlane only: (n, d) with n.X + d = 0 in this frame's camera coordinates, |n| = 1 and
  /// d >= 0 (n points to the camera's side). Zero for curved surfaces. Planar faces are
  /// bounded (a box face, a rim annulus), the plane is their supporting plane.
  Eigen::Vector4d plane = Eigen::Vector4d::Zero();
  std::uint16_t object_id = 0;  ///< owning object, 0 for room structure
  std::size_t pixel_count = 0;  ///< pixels labelled with this id in this frame (may be 0)
};

/// One object of the scene as seen in one frame.
struct TruthObject {
  std::uint16_t id = 0;  ///< the value in TruthFrame::object_labels (never 0)
  std::string kind;      ///< "table", "box", "bowl", "cup", "tin" or "ball"
  std::string name;      ///< e.g. "table", "box2", "bowl1"

  /// Tight oriented 3D box in camera coordinates. Axis 2 of `rotation` is the object's own
  /// axis (world up for upright objects, towards the opening for bowls and cups); size is
  /// the full extent along rotation's columns. corners[i] = center + rotation *
  /// (sx * size.x / 2, sy * size.y / 2, sz * size.z / 2) with (sx, sy, sz) = the bits of i
  /// (bit 0 -> x, 1 -> y, 2 -> z; 0 -> -1, 1 -> +1).
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< camera_from_object axes
  std::array<Eigen::Vector3d, 8> corners{};

  cv::Rect image_box;           ///< bounds of the labelled pixels, empty when not visible
  std::size_t pixel_count = 0;  ///< labelled pixels in this frame

  // Bowls only (defaults elsewhere).
  bool upright = true;  ///< opening faces world up
  /// Elevation of the camera above the bowl's rim plane, seen from the rim centre, using world
  /// up as the reference: asin(up . unit(camera - rim_centre)), degrees.
  double view_elevation_deg = 0.0;
  /// "top" (elevation > 60 deg), "middle" (20-60 deg), "side" (< 20 deg). Empty if no bowl.
  std::string view_class;
  Eigen::Vector3d rim_center = Eigen::Vector3d::Zero();  ///< camera frame
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();        ///< unit, towards the opening
  double rim_radius_m = 0.0;                             ///< outer radius at the rim
  double depth_m = 0.0;            ///< outer depth, rim plane to the outer bottom
  double shell_thickness_m = 0.0;  ///< also the rim width
  /// pixel_count over the area in pixels of the bowl's whole silhouette (its outer shell
  /// projected with nothing in front and no image border): how much of the bowl the sensor sees
  /// in this frame. 1 = all of it; less where other objects hide it, the image border cuts it
  /// or its pixels read no depth (nearer than KinectParams::min_range_m, shadows, dropouts). May
  /// exceed 1 by a few percent (whole pixels against an exact outline). 0 when not visible or
  /// when the bowl reaches behind the camera plane.
  double visible_fraction = 0.0;
};

/// The bowl view class for an elevation in degrees (thresholds 20 and 60, see TruthObject).
std::string bowlViewClass(double elevation_deg);

struct TruthFrame {
  cv::Mat surface_labels;  ///< CV_16UC1 surface id where the measured depth is valid, else 0
  cv::Mat object_labels;   ///< CV_16UC1 object id where the measured depth is valid, else 0
  /// CV_32FC1 noise-free z (m) of the first surface hit wherever it lies within the valid
  /// range, including pixels the sensor drops (shadows, dropouts, grazing); else 0.
  cv::Mat ideal_depth;
  std::vector<TruthSurface> surfaces;  ///< every surface of the scene, ordered by id
  std::vector<TruthObject> objects;    ///< every object of the scene, ordered by id
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

struct RenderedFrame {
  Frame frame;  ///< depth (mm), BGR colour, intrinsics, timestamp, sequence = index
  TruthFrame truth;
};

class SceneModel;  // the generated layout (driver/src/synthetic/scene_model.h)

/// A generated scene; renders any frame of its (endless) sequence.
class SyntheticScene {
 public:
  /// Generates the layout from params.seed. Throws std::invalid_argument on impossible params
  /// (empty ranges, non-positive frame rate or intrinsics).
  explicit SyntheticScene(SceneParams params);
  ~SyntheticScene();
  SyntheticScene(SyntheticScene&&) noexcept;
  SyntheticScene& operator=(SyntheticScene&&) noexcept;

  /// Renders frame `index`; timestamp_ns is only stored in the frame. Thread-safe.
  RenderedFrame render(std::uint64_t index, TimestampNs timestamp_ns) const;

  /// The camera pose of frame `index` (the same as render(index, ...).truth.world_from_camera).
  Eigen::Isometry3d worldFromCamera(std::uint64_t index) const;

  const SceneParams& params() const { return params_; }

 private:
  SceneParams params_;
  std::unique_ptr<const SceneModel> model_;
};

}  // namespace shapesense::synthetic
