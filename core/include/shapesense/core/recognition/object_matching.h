#pragma once
// Finding a taught object (object_model.h) in a depth frame, with a 6-DoF pose.
//
// Steps (findObject):
//   1. candidate matches: each model feature's nearest scene features by descriptor;
//   2. poses from them: each match gives a whole pose (the rotation carrying the model
//      feature's local frame onto the scene feature's); matches compatible with many others
//      (they turn the model alike and keep its distances, as a rigid motion does) anchor
//      poses fitted to the partners that agree with them, scored by the matches they carry;
//      the distinct poses with most, the poses that lay the model's flat faces and edges on
//      the scene's (flat_faces.h), and those that lay its box, or the box it stood in when
//      taught, on the scene's clusters (surface_clusters.h), ranked by how much of the model the
//      depth confirms near them, go on;
//   3. refinement of each by point-to-plane ICP of the model's surface on the scene's surface,
//      most confirmed first, until a verified pose (step 4) confirms as many model points as
//      the next one does before refinement; a pose that stands the model on a cluster's support
//      only turns about the support's normal;
//   4. verification in the depth: of the model's points that face the camera in that pose and
//      fall in the image, the share the depth confirms (a reading at the predicted depth, within
//      the sensor's noise) among those it confirms or contradicts (a reading behind where the
//      object would be); readings in front are occluders and count neither way. And the
//      outline: just beyond it, where the taught view shows that the object ends (object_model.h,
//      outline probes), the scene must not show surface at the probe's depth. A pose that few
//      matches agree with must be confirmed on most of the model (strong_inliers).
// The scene's surface and features are computed once per frame (SceneSurface) and shared by
// every model looked for.

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/core/recognition/object_model.h"

namespace shapesense {

/// One depth frame's surface and features, made once for all the models. The features are
/// described on first use (the first findObject): following an object from a known pose
/// (followObject) needs only the surface. Safe to share between threads.
class SceneSurface {
 public:
  /// `params` must be the models' (surface and feature parameters), so that the descriptors
  /// compare. Keeps a reference-counted copy of `depth_mm` (cv::Mat semantics). `mask`
  /// (CV_8UC1, optional: empty = every pixel) restricts the surface and its features to the
  /// pixels where it is non-zero: a surface for following objects whose poses are known
  /// (followObject) thins and indexes only their part of the image (the normals are still
  /// estimated on all of it). The depth check reads all of the depth. `planes` (optional):
  /// the frame's plane detection where one was made already (the detector chain's), which the
  /// flat faces are then read from instead of detecting the planes again.
  SceneSurface(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
               const ObjectModelParams& params = {}, const cv::Mat& mask = {},
               const PlaneDetection* planes = nullptr);
  ~SceneSurface();
  SceneSurface(const SceneSurface&) = delete;
  SceneSurface& operator=(const SceneSurface&) = delete;

  const SurfaceCloud& surface() const { return surface_; }
  const std::vector<ShapeFeature>& features() const;
  /// The frame's planes as flat faces, and their convex edges (flat_faces.h): from the planes
  /// given, or from planes detected on first use.
  const FlatFaces& flatFaces() const;
  /// The surface off the frame's large flat faces in connected clusters, each as a box
  /// (surface_clusters.h): made on first use.
  const std::vector<SurfaceCluster>& clusters() const;
  /// The features' descriptors dimension-major: value d of feature i at
  /// [d * features().size() + i] (the layout descriptor matching reads).
  const std::vector<float>& descriptorColumns() const;
  const cv::Mat& depth() const { return depth_mm_; }
  const CameraIntrinsics& intrinsics() const { return intrinsics_; }

 private:
  void describe() const;
  void findFlatFaces(const PlaneDetection& planes) const;

  cv::Mat depth_mm_;
  CameraIntrinsics intrinsics_;
  SurfaceCloud surface_;
  ShapeFeatureParams feature_params_;
  FlatFaceParams flat_face_params_;
  SurfaceClusterParams cluster_params_;
  mutable std::once_flag described_;
  mutable std::vector<ShapeFeature> features_;
  mutable std::vector<float> descriptor_columns_;
  mutable std::once_flag flat_faces_found_;
  mutable FlatFaces flat_faces_;
  mutable std::once_flag clustered_;
  mutable std::vector<SurfaceCluster> clusters_;
};

struct ObjectMatchParams {
  /// Scene features matched to each model feature (nearest descriptors first). Default 20.
  int matches_per_feature = 20;
  /// Matches that anchor a pose, those with the most compatible partners first. Default 300.
  int anchors = 300;
  /// A match agrees with a pose when the posed model feature lies this close to its scene
  /// feature (m). Default 1.5 cm.
  float inlier_distance_m = 0.015f;
  /// Two compatible matches: the distance between their model points and between their scene
  /// points differ by at most this (m). Default 1 cm.
  float pair_tolerance_m = 0.01f;
  /// ...the rotations they give (each carrying the model feature's local frame onto the scene
  /// feature's) differ by at most this angle (deg). Default 20.
  float max_frame_disagreement_deg = 20.0f;
  /// ...and their points lie at least this far apart (m): near points fix no rotation together.
  /// Default 2 cm.
  float min_sample_spacing_m = 0.02f;
  /// Fewest agreeing matches (distinct model interest points) for a pose to be refined.
  /// Default 4.
  int min_inliers = 4;
  /// A pose from the features that fewer than `strong_inliers` matches agree with is weak
  /// evidence (a few corner matches fit many boxes): it stands only where the depth confirms
  /// at least `weak_pose_confirmed_share` of the model's points. Poses laid by flat faces
  /// (poses_from_flat_faces) rest on the faces' geometry instead. Defaults 7 and 0.9 (chosen on
  /// the validation split, docs/benchmarks.md).
  int strong_inliers = 7;
  float weak_pose_confirmed_share = 0.9f;
  /// A pose that stands the model on a cluster as it stood when taught (standingPoses) rests on
  /// the support, the cluster's sides and its size, so it needs less: this share of the
  /// model's points confirmed. Default 0.6 (chosen on the validation split, with the
  /// object-free scenes' false detections held at their record; docs/benchmarks.md).
  float standing_pose_confirmed_share = 0.6f;
  /// Distinct poses (apart by 2 cm or 10 deg at the model's centre) with the most agreeing
  /// matches that are checked in the depth; of those, the `pose_hypotheses` the depth confirms
  /// most (before ICP, within its reach) are refined and checked again, in that order, until
  /// a verified pose confirms as many points as the next one did before ICP; the one the depth
  /// confirms most wins. Defaults 30 and 5.
  int pose_candidates = 30;
  int pose_hypotheses = 5;
  /// ...and besides those, the poses laid by flat faces (poses_from_flat_faces) the depth
  /// confirms most, at most this many: a wrong pose that many features agree with often
  /// outranks them. Default 3.
  int flat_face_hypotheses = 3;
  /// ...and the poses laid on clusters (poses_from_clusters) the depth confirms most, at most
  /// this many. Default 2.
  int cluster_hypotheses = 2;
  /// Point-to-plane ICP with nearest-point pairs: iterations for each pose from step 2 on at
  /// most `icp_max_points` of the model (evenly spread), then iterations on all of it for the
  /// pose that wins the check, and the farthest pair it uses (m). Defaults 15, 5, 500, 2 cm.
  int icp_iterations = 15;
  int icp_final_iterations = 5;
  float icp_max_distance_m = 0.02f;
  int icp_max_points = 500;
  /// Weight of each pair's point-to-point gap beside its point-to-plane distance in ICP: the
  /// plane term alone lets a box face or a tin's side slide along itself by a centimetre or
  /// two where the rest of the object is hidden. Default 0.02: the largest weight on the
  /// validation split that keeps a tin model from verifying on larger tins of other scenes
  /// (docs/benchmarks.md); 0 = point-to-plane alone.
  float icp_point_to_point_weight = 0.02f;
  /// A depth reading confirms a model point within max(this, confirm_steps sensor depth
  /// steps) of its predicted depth (m). Defaults 1 cm and 3 steps.
  float confirm_distance_m = 0.01f;
  float confirm_steps = 3.0f;
  /// Smallest share of confirmed points for a detection. Default 0.95.
  float min_score = 0.95f;
  /// Fewest model points the depth must confirm, as a share of the model's points: a pose that
  /// shows only part of the object (the rest hidden behind other surfaces, or facing away) is
  /// not evidence enough; corners and edges of other boxes fit a part. Default 0.5, the least
  /// of an object that must be visible for it to be found.
  float min_confirmed_share = 0.5f;
  /// Of the model's outline probes (object_model.h), at least this share must be seen (a
  /// reading not in front of them): an object whose outline is hidden or out of view cannot be
  /// told from a part of something larger. Default 0.3.
  float min_seen_outline = 0.3f;
  /// ...and at most this share of those seen may show surface at the probe's depth: more
  /// means the match is part of a larger thing, or the object slid along a face. Default 0.02
  /// (chosen on the validation split and the training cases, docs/benchmarks.md).
  float max_continued_outline = 0.02f;
  /// A probe shows surface at its depth when the reading there is within this of the probe's
  /// depth (m). Less than the probes' distance from the outline
  /// (ObjectModelParams::outline_probe_offset_m): another view that sees the object's own side,
  /// which runs back from the outline, reads it that far behind the probe or more. Default 1 cm.
  float outline_continuation_m = 0.01f;
  /// Poses also come from the model's flat faces and edges (ObjectModel::flat_faces) laid on
  /// the scene's (SceneSurface::flatFaces, flat_faces.h): edges where the angles between their
  /// faces agree within edge_angle_tolerance_deg and the scene's edge and faces are no larger
  /// than the model's by more than face_size_slack_m; for a model without an edge (one face
  /// in view), faces whose sides agree within face_size_slack_m. A box whose interest points
  /// do not recur is still found by its faces. Defaults true, 5 deg, 3 cm (chosen on the
  /// validation split, docs/benchmarks.md).
  bool poses_from_flat_faces = true;
  float edge_angle_tolerance_deg = 5.0f;
  float face_size_slack_m = 0.03f;
  /// At most this many poses from flat faces for one model in one frame (the model's edges in
  /// turn, each laid on the scene's edges in their order): each is checked in the depth, and a
  /// frame of many planes would make model edges x scene edges x 4 of them. Default 256 (the
  /// validation split's most is 46): the depth checks of a frame of many planes stay bounded.
  int max_flat_face_poses = 256;
  /// Poses also come from the model's box laid on the boxes of the scene's clusters
  /// (SceneSurface::clusters, surface_clusters.h) whose sizes agree within cluster_size_slack
  /// (similarBoxSizes, 24 poses a cluster), and from the model's standing box stood on theirs
  /// where both stand on a support (similarStandingSizes, 4 poses a cluster): an object with
  /// too few interest points and no flat face, as a bowl, or whose faces the scene's planes
  /// miss, is still found where it stands apart. They compete with the features' poses for
  /// the pose_hypotheses refined, besides cluster_hypotheses of their own; at most
  /// max_cluster_poses of them for one model in one frame. Defaults true, 0.4, 240 (chosen on the
  /// validation split, docs/benchmarks.md).
  bool poses_from_clusters = true;
  float cluster_size_slack = 0.4f;
  int max_cluster_poses = 240;
  /// Sensor noise model for confirm_steps.
  KinectNoiseModel noise{};
};

struct ObjectDetection {
  std::string name;
  Eigen::Isometry3f camera_from_model = Eigen::Isometry3f::Identity();
  float score = 0.0f;        ///< share of the visible model points the depth confirms
  int confirmed_points = 0;  ///< model points the depth confirms
  int feature_inliers = 0;   ///< model features that agree with the pose (step 2)
  OrientedBox box;           ///< the model's box in the camera frame
};

/// Of the poses of `model` in `scene` that pass the verification, the one the depth confirms
/// most; or none.
std::optional<ObjectDetection> findObject(const ObjectModel& model, const SceneSurface& scene,
                                          const ObjectMatchParams& params = {});

/// Follows an object from where it was a moment ago (`prior`: the previous frame's
/// detection): steps 3 and 4 from `prior`, without features. Far cheaper than findObject while
/// the object moves less between frames than ICP reaches (a few centimetres at the object);
/// none when the depth does not confirm the refined pose (the object moved farther, left or
/// was hidden): findObject then searches the frame. feature_inliers is left 0.
std::optional<ObjectDetection> followObject(const ObjectModel& model, const SceneSurface& scene,
                                            const Eigen::Isometry3f& prior,
                                            const ObjectMatchParams& params = {});

/// The part of the image followObject reads from `prior` (the posed model with what ICP may
/// reach around it): a SceneSurface made on this region alone follows the object as one made
/// on the whole image does. Empty when the model has no points or the region lies outside the
/// image.
cv::Rect followObjectRegion(const ObjectModel& model, const Eigen::Isometry3f& prior,
                            const CameraIntrinsics& intrinsics,
                            const ObjectMatchParams& params = {});

/// What the depth says of `model` at a pose (step 4), and the first of its rules the pose
/// fails, if any.
struct PoseCheck {
  int confirmed = 0;          ///< model points facing the camera whose reading confirms them
  int contradicted = 0;       ///< ...whose reading lies behind them (the depth sees through them)
  int outline_seen = 0;       ///< outline probes with a reading not in front of them
  int outline_continued = 0;  ///< ...showing surface at the probe's depth
  float score = 0.0f;         ///< confirmed / (confirmed + contradicted); 0 with neither
  /// Empty when the pose passes; else which rule it fails, with its figures where it has any,
  /// e.g. "score 0.9300 < 0.95".
  std::string failed;
};

/// The check of step 4 of `model` at `camera_from_model`, with its figures: what
/// verifyObjectPose decides by, for a pose that one wants to understand (why an object was not
/// found where it is).
PoseCheck checkObjectPose(const ObjectModel& model, const SceneSurface& scene,
                          const Eigen::Isometry3f& camera_from_model,
                          const ObjectMatchParams& params = {});

/// Step 4 alone: `model` at `camera_from_model` as a detection if the depth confirms it (a pose
/// from elsewhere: the last frame's, another method's). feature_inliers is left 0.
std::optional<ObjectDetection> verifyObjectPose(const ObjectModel& model, const SceneSurface& scene,
                                                const Eigen::Isometry3f& camera_from_model,
                                                const ObjectMatchParams& params = {});

}  // namespace shapesense
