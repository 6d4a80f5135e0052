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
//  With the wider distribution's params (all off by default, see the end of SceneParams) also:
//  extra boxes 3-60 cm, stacked boxes (on a box's top), touching pairs of boxes, books, boards
//  and lids (kinds "book", "board", "lid") on the table or on box tops, shelf units against a
//  wall ("shelf"), tins lying on their side, open bins ("bin") and columns ("column") on the
//  floor, tori and smooth mounds (height fields) on the table; a free-look camera in a room drawn
//  by size; extra camera roll; and the sensor artefacts flying pixels and holes (KinectParams).
//  Objects then also rest on box tops, books, boards and shelf boards.
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

  // Artefacts of the wider scene distribution (issue #18). Each is off by default, and off it
  // draws no random number. Their draws come from streams of their own (seeded from the scene
  // seed and the frame index), so switching one on changes no other pixel's noise.

  /// Share of depth-edge pixels that read a "flying" depth between the two sides of the edge:
  /// a pixel whose ideal depth differs from a 4-neighbour's by more than
  /// flying_pixel_min_jump_m reads, with this probability, its own depth moved a uniform
  /// fraction of the way to the neighbour's (then the disparity noise as usual). Flying pixels
  /// keep the label of the surface their ray hits; ideal_depth stays the true depth.
  /// Default 0 (off); sensible 0-0.5.
  double flying_pixel_rate = 0.0;
  double flying_pixel_min_jump_m = 0.05;  ///< depth step that makes an edge (m). Default 0.05.
  /// Holes: per frame, a number of blobs drawn uniformly from [holes_min, holes_max], each 1-3
  /// overlapping ellipses of semi-axes hole_radius_min_px-hole_radius_max_px at a uniform image
  /// position, read no depth (and carry no label). Independent per frame. Default 0-0 (off).
  int holes_min = 0;
  int holes_max = 0;
  double hole_radius_min_px = 3.0;   ///< Default 3.
  double hole_radius_max_px = 25.0;  ///< Default 25.
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

  // ---- The wider scene distribution (issue #18) ----
  // Every default below switches its feature off, and a feature that is off draws no random
  // number: with the defaults every scene is what it was. All but free_look draw from a layout
  // stream of their own (seeded from `seed`), so they add to a scene without moving what the
  // fields above put in it; free_look replaces the camera, table and room placement.

  /// Extra camera roll about the viewing direction, uniform in +-camera_roll_max_deg (deg), on
  /// top of the +-1 deg every scene has. Default 0 (off); sensible 0-10.
  double camera_roll_max_deg = 0.0;

  /// Free look: instead of standing 0.8-2.5 m from the table and looking at its centre, the
  /// camera stands anywhere beside the table, free_look_height_min_m-free_look_height_max_m
  /// above the floor, looks towards a random point of the table area grown by
  /// free_look_target_spread_m (azimuth only) and is pitched down by
  /// free_look_pitch_min_deg-free_look_pitch_max_deg. The table stands
  /// free_look_table_distance_min_m-free_look_table_distance_max_m (horizontal) from the camera
  /// and the room is drawn by size (room_extent_*, room_height_*) around both, so walls may be
  /// out of range or out of view. min_table_elevation_deg, camera_height_* and
  /// table_distance_* are not used. Default false.
  bool free_look = false;
  double free_look_height_min_m = 0.4;          ///< Default 0.4.
  double free_look_height_max_m = 2.0;          ///< Default 2.0.
  double free_look_pitch_min_deg = 0.0;         ///< down from horizontal. Default 0.
  double free_look_pitch_max_deg = 60.0;        ///< Default 60.
  double free_look_table_distance_min_m = 0.8;  ///< Default 0.8.
  double free_look_table_distance_max_m = 3.5;  ///< Default 3.5.
  double free_look_target_spread_m = 1.0;       ///< Default 1.
  /// Free look only: room width and depth (each drawn uniformly; widened when camera and table
  /// would not fit) and height (m). Defaults 3-7 and 2.4-3.
  double room_extent_min_m = 3.0;
  double room_extent_max_m = 7.0;
  double room_height_min_m = 2.4;
  double room_height_max_m = 3.0;

  /// More boxes (kind "box", named on from the boxes above), each side drawn log-uniformly from
  /// [extra_box_size_min_m, extra_box_size_max_m]; on the table when it fits there (and a coin
  /// says so), else on the floor anywhere in view. Default 0-0 (off); sizes default 0.03-0.6.
  int extra_boxes_min = 0;
  int extra_boxes_max = 0;
  double extra_box_size_min_m = 0.03;
  double extra_box_size_max_m = 0.6;
  /// Stacked boxes: a box (4-30 cm, kind "box") lying on the top face of a box already placed,
  /// inside its top. Default 0-0 (off).
  int stacked_boxes_min = 0;
  int stacked_boxes_max = 0;
  /// Touching pairs: two boxes (kind "box") side by side with a 0-1 cm gap, both with the same
  /// yaw; half of the pairs with their fronts in one plane; a third with equal heights (one
  /// top plane), a third with heights 1-3 cm apart. On the table, or on the floor when the pair
  /// does not fit. Default 0-0 (off).
  int touching_box_pairs_min = 0;
  int touching_box_pairs_max = 0;
  /// Thin objects lying flat, 1-3 cm proud of what they lie on: books (kind "book", 12-30 x
  /// 10-22 cm, 1.5-3 cm thick), boards ("board", 20-45 x 15-30 cm, 1-2.5 cm) and lids ("lid",
  /// discs of radius 5-12 cm, 1-2 cm: surfaces "lid<k>_top", "_bottom" planes and "_side"
  /// curved). On a box top when one has room (half the time) else on the table; one that
  /// finds no room is shrunk (length and width by 0.75, up to twice) before it is left out.
  /// Box faces are named like boxes' ("book1_face_top"). Default 0-0 (off).
  int thin_objects_min = 0;
  int thin_objects_max = 0;
  /// Whether lids are among the thin objects (their rim is a curved surface); false draws
  /// books and boards only. Default true.
  bool thin_object_lids = true;
  /// Shelf units (kind "shelf") standing against the back, left or right wall: 0.6-1.2 m wide,
  /// 0.25-0.4 m deep, 0.8-2 m tall, two side panels "shelf<k>_side{1,2}_face_*", 2-4 boards
  /// "shelf<k>_board<j>_face_*" and half the time a back panel "shelf<k>_back_face_*", all
  /// planar; half the boards below the top hold a box. A unit that finds no free stretch of
  /// wall is left out. Default 0-0 (off).
  int shelves_min = 0;
  int shelves_max = 0;
  /// Tins lying on their side on the table (kind "tin", radius 3-6 cm, 8-20 cm long; "_side"
  /// curved, "_top" and "_bottom" planes, now vertical). Default 0-0 (off).
  int lying_tins_min = 0;
  int lying_tins_max = 0;
  /// Open bins on the floor (kind "bin": radius 12-25 cm, 30-70 cm tall, surfaces like a cup's
  /// "bin<k>_outer", "_inner" curved, "_rim", "_inner_bottom", "_bottom" planes). Default 0-0.
  int bins_min = 0;
  int bins_max = 0;
  /// Floor-to-ceiling columns (kind "column": radius 10-25 cm, "column<k>_side" curved).
  /// Default 0-0 (off).
  int columns_min = 0;
  int columns_max = 0;
  /// Tori lying flat on the table (kind "torus": ring radius 4-12 cm, tube radius 1-3 cm; one
  /// curved surface "torus<k>"). Default 0-0 (off).
  int tori_min = 0;
  int tori_max = 0;
  /// Smooth mounds on the table (kind "mound": a height field over 20-50 x 20-50 cm, 3-12 cm
  /// high, 1-3 Gaussian bumps under a window that takes it to 0 at the border; surface
  /// "mound<k>_top" curved and "mound<k>_base" the plane it rests on). Smaller when the table
  /// is crowded. Default 0-0 (off).
  int mounds_min = 0;
  int mounds_max = 0;
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
  /// "table", "box", "bowl", "cup", "tin" or "ball"; with the wider distribution's features
  /// also "book", "board", "lid", "shelf", "bin", "column", "torus" and "mound".
  std::string kind;
  std::string name;  ///< e.g. "table", "box2", "bowl1"

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

  /// Renders frame `index` as a camera at `world_from_camera` sees the scene: the same layout
  /// from another viewpoint, with frame `index`'s sensor noise. For data sets that need one
  /// scene from several known poses (teach an object in one view, find it in another: the truth
  /// transform between two views is camera_b_from_world * world_from_camera_a). The truth is in
  /// that camera's coordinates and truth.world_from_camera is the given pose. Given
  /// worldFromCamera(index) it is render(index, timestamp_ns), byte for byte. Thread-safe.
  RenderedFrame render(std::uint64_t index, TimestampNs timestamp_ns,
                       const Eigen::Isometry3d& world_from_camera) const;

  /// The camera pose of frame `index` (the same as render(index, ...).truth.world_from_camera).
  Eigen::Isometry3d worldFromCamera(std::uint64_t index) const;

  const SceneParams& params() const { return params_; }

 private:
  SceneParams params_;
  std::unique_ptr<const SceneModel> model_;
};

}  // namespace shapesense::synthetic
