#pragma once
// Ground truth for object recognition ("teach an object, find it again", issue 22): one
// table-top layout seen from several camera poses, with the exact transform between the views.
// An object is taught from one view (its frame and the truth image_box as the ROI) and must be
// found, with its 6-DoF pose, in the others. Cases come in the evaluation's splits: choose
// parameters on validation, report test.
//
// The scenes: a table 0.7-2 m from a static camera 0.9-1.6 m above the floor (no free look, no
// sway), with 2-4 boxes of 6-32 cm on the table and 1-2 smaller ones of 5-25 cm (on the table
// three times in five, else on the floor in view), in 30% of the scenes with at most 5 boxes one
// more (4-30 cm) stacked on another: 3-6 boxes in all. In 40% of the scenes 1-2 books, boards or
// lids, and 0-2 cups, 0-2 tins, 0-1 bowl; no balls. A crowded table leaves out what finds no
// room. Sensor noise 0.05-0.1 px of disparity, no holes, no flying pixels; depth only (no colour
// image).
//
// The other views orbit the teach camera about the vertical line through the table's centre by
// +-10-35 deg (azimuth, sign random), raise or lower it by up to 15 cm and tilt it (about its
// own x axis, so its roll stays) to look at the point of the table top the teach camera looked
// at. A view that would put the camera within 30 cm of a wall, the floor or the ceiling, or
// above the table, is drawn again. Each view is a different frame index of the scene, so its
// sensor noise is its own.

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/scene_splits.h"

namespace shapesense::eval {

/// One view of a case's layout: the frame with its truth (in this view's camera frame) and the
/// camera pose it was rendered from (also rendered.truth.world_from_camera).
struct RecognitionView {
  synthetic::RenderedFrame rendered;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

/// One layout seen from a teach view and from other views. Truth object ids are the same in
/// every view (the layout is the same).
struct RecognitionCase {
  synthetic::SceneParams params;        ///< the layout (and the sensor noise model)
  RecognitionView teach;                ///< the view an object is taught from
  std::vector<RecognitionView> others;  ///< the same layout from other camera poses
};

/// Case `index` (>= 0) of a split with `other_views` (>= 0) views besides the teach view: a pure
/// function of (split, index, other_views), and the first n other views do not depend on how
/// many are asked for. Seeds 4'000'000 (train), 5'000'000 (validation), 6'000'000 (test) plus
/// index: disjoint from evalScene's and from each other split's. Throws std::invalid_argument on
/// a negative index or count.
RecognitionCase recognitionCase(Split split, int index, int other_views = 3);

/// The truth transform that maps a point in the teach view's camera frame to `view`'s camera
/// frame: camera_v_from_world * world_from_camera_teach. A found object's pose (camera_v from
/// object) should equal teachToView * (camera_teach from object).
Eigen::Isometry3d teachToView(const RecognitionCase& c, const RecognitionView& view);

/// The ids of the objects one can teach from the teach view, in id order: objects of kind box,
/// book, board, lid, cup, tin, bowl, torus or mound (the table, shelves, bins, balls and columns
/// are not taught; the case scenes hold no tori, mounds, shelves, bins or columns) whose
/// labelled pixels span at least 24 x 24 px, number at least 2000 (~0.65% of a 640 x 480 image)
/// and do not touch the image border (a cut object's model would be cut too). About 4 per case;
/// none in a few cases (1 of the first 600 of the three splits), which a benchmark skips.
std::vector<std::uint16_t> teachableObjects(const RecognitionCase& c);

/// How much of object `object_id` `view` shows, relative to the teach view: its labelled pixels
/// in `view` over its labelled pixels in the teach view, capped at 1 (0 when the teach view does
/// not show it). A proxy: the share of its unoccluded silhouette would need another rendering
/// without the other objects; this one also moves with distance (a nearer view shows more
/// pixels) and with the side the object is seen from.
double visibleShare(const RecognitionCase& c, const RecognitionView& view, std::uint16_t object_id);

}  // namespace shapesense::eval
