#pragma once
// Bowl datasets for shapesense-train: a folder of depth frames with bowl annotations.
//
// Layout (version 2; version 1 had no pixels or visible_fraction):
//   <dir>/dataset.json       {"format": "shapesense-bowl-dataset", "version": 2,
//                             "generator": {...how it was made...}}
//   <dir>/annotations.jsonl  one line per frame: {"file": "frames/000123.png",
//                             "fx": .., "fy": .., "cx": .., "cy": .., "negative": bool,
//                             "bowls": [{"box": [x, y, w, h], "view": "middle",
//                                        "upright": true, "pixels": 812,
//                                        "visible_fraction": 0.93, "difficult": false},
//                                       ...]}
//   <dir>/frames/*.png       16-bit depth, millimetres, 0 = no reading
// Frames of the bowl generator's table-top scenes come first (frames_per_scene per scene), then
// one frame of each "wide" scene (GenerateParams::wide_scenes): scenes of the evaluation's
// scene distribution (tools/eval scene_splits.h: rooms, furniture, clutter, camera poses at
// many heights), annotated by the same code.
// "negative" frames hold no upright bowl and feed the bootstrapping; the others give the
// positives (BowlAnnotation::trainable, from "upright", "box" and "pixels") and the evaluation
// truth (upright bowls; "difficult" ones ignored, core/bowl_eval.h isDifficultBowl).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense::train {

struct BowlAnnotation {
  cv::Rect box;
  std::string view;
  bool upright = true;
  /// The evaluation ignores it (isDifficultBowl in core/bowl_eval.h).
  bool difficult = false;
  /// A training positive (derived on reading): upright and not tiny or sparse
  /// (isTinyOrSparseBowl; in version 1 datasets: not difficult). Partly hidden
  /// bowls are kept here (they teach partial views) although the evaluation does not require
  /// them.
  bool trainable = false;
};

struct DatasetFrame {
  std::string file;  // relative to the dataset folder
  CameraIntrinsics intrinsics;
  bool negative = false;
  std::vector<BowlAnnotation> bowls;
};

struct GenerateParams {
  std::uint64_t seed = 1;
  int positive_scenes = 240;  // scenes with upright bowls, a quarter per camera preset
  int negative_scenes = 120;  // scenes without upright bowls (upside-down ones allowed)
  int frames_per_scene = 2;   // frames 0 and 45 (1.5 s of camera sway apart)
  /// Fraction of frames whose room (floor, walls: object id 0) reads no depth, as in
  /// recordings whose background was cut away. Default 0.5.
  double blank_room_fraction = 0.5;
  /// Frames from the evaluation's wide scene distribution, appended after the scenes above:
  /// frame k is eval::evalScene(wide_split, wide_first + k) at its scored frame index, room
  /// kept (never blanked). Those without an upright bowl are negatives for the bootstrapping,
  /// upright bowls are positives and truth, as in every frame. Train only on "train" (the
  /// default); "validation" makes a validation set, "test" a test set.
  int wide_scenes = 0;
  int wide_first = 0;
  std::string wide_split = "train";
  int threads = 2;
};

/// Renders synthetic scenes into `dir` (created). Prints progress to stderr.
void generateDataset(const std::filesystem::path& dir, const GenerateParams& params);

std::vector<DatasetFrame> readDataset(const std::filesystem::path& dir);

/// Throws unless the dataset's "difficult" flags follow the current truth rule (version >= 2):
/// evaluation (eval, diagnose, the bench) calls it; training reads version 1 too.
void requireEvaluationTruth(const std::filesystem::path& dir);

/// Reads one frame's depth (CV_16UC1 mm).
cv::Mat readDepth(const std::filesystem::path& dir, const DatasetFrame& frame);

}  // namespace shapesense::train
