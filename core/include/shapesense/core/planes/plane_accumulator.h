#pragma once
// Planes accumulated over time (SRS D4.6.2 section 2.2: the global Hough space and its
// "thinning").
//
// Each frame's planes are added to a global HoughAccumulator as Gaussians of weight 1, and every
// update first decays the whole space (multiply by `decay`, then subtract `thinning`), so a
// plane's peak approaches 1 / (1 - decay) while it stays in view and fades once it leaves it;
// one-off artefacts never reach `min_peak`. The reported planes are the maxima of the global
// space >= min_peak; their parameters come from tracks: each frame plane joins the track it
// matches (angle and distance gates) and a track keeps decayed, inlier-weighted sums of the
// normal and of a point on the plane, so the accumulated equation is an average over frames
// (the per-frame noise averages out; the Hough cell only says *which* planes are stable).
//
// Moving sensor. The space lives in a fixed reference frame so that it does not smear:
//  - with poses (world_from_camera per frame): the reference is the camera frame of the first
//    frame (or of the last reset); planes are moved into it with the pose. It is reset when the
//    camera has turned more than `max_rotation_deg` from it (the Lambert map of the space is
//    centred on the reference camera's viewing direction and loses normals beyond ~100 deg),
//    or when poses stop or start being given.
//  - without poses: the camera frame is the reference and the space is reset on a large
//    change: when at least `reset_min_planes` tracks are established and less than
//    `reset_matched_fraction` of the frame's inliers fall on planes matching an established
//    track (a moved camera sees every plane at a new (n, d)). A small sway (a degree, a few
//    cm) stays within the match gates and is averaged in.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "shapesense/core/planes/hough_accumulator.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {

struct PlaneAccumulatorParams {
  /// Global space resolution. Default 1 deg x 1 cm up to 12 m (finer than per frame: its input
  /// is refined planes, not raw votes).
  HoughSpaceParams space{1.0, 0.01, 12.0, 1.6};
  /// Gaussian each frame plane adds. Defaults 1 deg, 1 cm.
  double sigma_angle_deg = 1.0;
  double sigma_d_m = 0.01;
  /// Per-update decay factor and subtractive thinning. Defaults 0.9 (a plane in view converges
  /// to a peak of ~10 x the central kernel weight; one that left fades by 10x in 22 frames) and
  /// 1e-4 (frees the long tails).
  float decay = 0.9f;
  float thinning = 1e-4f;
  /// A global maximum is reported when its peak is at least this many frames' worth of the
  /// kernel's central weight (decayed). Default 2.5.
  double min_frames = 2.5;
  /// Matching a frame plane to a track. Defaults 3 deg and 3 cm.
  double match_angle_deg = 3.0;
  double match_distance_m = 0.03;
  /// Reset rules (see file comment). Defaults 60 deg, 3 tracks, 0.5.
  double max_rotation_deg = 60.0;
  int reset_min_planes = 3;
  double reset_matched_fraction = 0.5;
};

class PlaneAccumulator {
 public:
  explicit PlaneAccumulator(PlaneAccumulatorParams params = {});

  /// Adds one frame's detection. `world_from_camera`: the frame's pose when known.
  void update(const PlaneDetection& frame,
              const std::optional<Eigen::Isometry3d>& world_from_camera = std::nullopt);

  /// The accumulated planes in the camera frame of the last update; `id` is a track id, stable
  /// across frames; inliers, rms, box, polygon and colour are those of the track's last sighting
  /// (polygon moved into the current camera frame).
  std::vector<DetectedPlane> planes() const;

  void reset();
  std::size_t frames() const { return frames_; }
  std::size_t resets() const { return resets_; }
  const HoughAccumulator& space() const { return space_; }

 private:
  struct Track {
    std::uint16_t id = 0;
    Eigen::Vector3d sum_normal = Eigen::Vector3d::Zero();  // reference frame, weighted
    Eigen::Vector3d sum_point = Eigen::Vector3d::Zero();
    double weight = 0.0;
    Eigen::Vector3d normal() const { return sum_normal.normalized(); }
    double d() const { return -normal().dot(sum_point / weight); }
    DetectedPlane last;  // in the camera frame of its sighting
    Eigen::Isometry3d ref_from_last = Eigen::Isometry3d::Identity();
  };
  int matchTrack(const Eigen::Vector3d& n, double d) const;

  PlaneAccumulatorParams params_;
  HoughAccumulator space_;
  std::vector<Track> tracks_;
  std::uint16_t next_id_ = 1;
  std::optional<Eigen::Isometry3d> world_from_ref_;
  bool had_pose_ = false;
  Eigen::Isometry3d ref_from_camera_ = Eigen::Isometry3d::Identity();
  std::size_t frames_ = 0;
  std::size_t resets_ = 0;
};

}  // namespace shapesense
