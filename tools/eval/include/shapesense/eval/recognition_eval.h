#pragma once
// Scoring of taught-object recognition (core/recognition) on the recognition cases
// (recognition_views.h): each teachable object is taught as an operator would (its truth image
// box as the ROI, the object that ROI marks after the detector chain has run on the teach
// frame), then looked for in the other views. Issue 22's measure: recall at a pose error of at
// most 1 cm and 5 deg where at least half of the object is visible, and false detections per
// frame for five taught objects.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/eval/recognition_views.h"
#include "shapesense/eval/recognizer.h"

namespace shapesense::eval {

/// How a found pose is judged.
struct PoseTolerance {
  double translation_m = 0.01;
  double rotation_deg = 5.0;
  /// A view must show at least this share of the object (visibleShare) for it to be required;
  /// below `min_visible_share_present` a detection is false whatever its pose.
  double min_visible_share = 0.5;
  double min_visible_share_present = 0.1;
};

struct PoseErrorDeg {
  double translation_m = 0.0;
  double rotation_deg = 0.0;
};

/// One detection as it was judged: enough to count it again at another detection threshold.
struct ScoredDetection {
  std::string kind;            ///< the object's (synthetic::TruthObject::kind)
  double score = 0.0;          ///< the method's (RecognizerDetection::score)
  double visible_share = 0.0;  ///< visibleShare of the object in the searched view
  PoseErrorDeg error;
};

/// A required object (RecognitionScore::required) that was not found within the tolerance.
struct RecognitionMiss {
  int case_index = 0;
  int view = 0;  ///< index among the case's other views
  std::string object;
  double visible_share = 0.0;
  std::optional<PoseErrorDeg> detected;  ///< the error of the pose reported, if one was
  /// The method's own check (Recognizer::checkPose) of the truth pose, and of the pose
  /// reported when one was; none for a method without such a check.
  std::optional<PoseVerdict> truth_check;
  std::optional<PoseVerdict> reported_check;
};

struct RecognitionScore {
  int cases = 0;
  int views = 0;             ///< other views searched
  int taught = 0;            ///< objects taught
  int refused = 0;           ///< teachable objects the ROI could not teach (reasons counted below)
  int required = 0;          ///< (object, view) pairs that must be found
  int found = 0;             ///< ...found within the tolerance
  int wrong_pose = 0;        ///< ...detected with a pose outside it (also counted false)
  int false_detections = 0;  ///< detections not within the tolerance of a present object
  std::vector<double> translation_errors_m;  ///< of the found ones
  std::vector<double> rotation_errors_deg;
  double describe_ms_total = 0.0;  ///< Recognizer::describe (SceneSurface), summed over views
  double find_ms_total = 0.0;      ///< Recognizer::find (findObject), summed over (model, view)
  int searches = 0;                ///< Recognizer::find calls
  std::vector<ScoredDetection> detections;  ///< every detection, in the order made
  std::vector<RecognitionMiss> misses;      ///< at the method's own threshold
  struct KindRecall {
    int required = 0;
    int found = 0;
  };
  std::map<std::string, KindRecall> by_kind;  ///< required and found, by the objects' kind

  double recall() const { return required ? static_cast<double>(found) / required : 0.0; }
  /// False detections per frame, scaled to five taught objects (the measure).
  double falsePerFrameForFive() const;
};

/// The turns under which an object's shape is the same, so that depth alone cannot tell them
/// apart: none; any turn about its axis (tins, cups, lids, bowls, tori: solids of revolution
/// about their z axis); a half turn about any of its three axes, and a quarter turn about one
/// whose two other sides are alike (boxes, books and boards: plain cuboids; see poseError).
enum class ObjectSymmetry { kNone, kAxial, kCuboid };

/// The symmetry of a synthetic object of kind `kind` (synthetic::TruthObject::kind).
ObjectSymmetry symmetryOfKind(const std::string& kind);

/// Pose error of `estimated` (camera from model, the model in the teach camera's frame)
/// against `truth` (teachToView), at `centre` (model frame), the least over the poses the
/// object's `symmetry` makes look the same (as the BOP benchmark scores symmetric objects).
/// `axes`: the object's axes (columns, model frame); for kAxial column 2 is its axis.
/// For kCuboid, `size` is the full extent along each axis, and a turn of the box onto its own
/// axes counts as a symmetry when it moves none of its corners further than `alike_m`: a half
/// turn always, a quarter turn when the two sides it swaps differ by at most sqrt(2) alike_m
/// (a box 23.9 x 23.6 cm turned a quarter shows the same surface to within 2 mm). Pass the
/// pose tolerance's translation: a turn that moves the surface less than an accepted shift is
/// no wrong pose.
PoseErrorDeg poseError(const Eigen::Isometry3f& estimated, const Eigen::Isometry3d& truth,
                       const Eigen::Vector3d& centre, const Eigen::Matrix3d& axes,
                       ObjectSymmetry symmetry, const Eigen::Vector3d& size, double alike_m);

/// Scores cases [first, first + count) of a split with `other_views` views each: shapesense's
/// own method (ShapesenseRecognizer with these parameters).
RecognitionScore scoreRecognition(Split split, int first, int count, int other_views = 3,
                                  const ObjectModelParams& model_params = {},
                                  const ObjectMatchParams& match_params = {},
                                  const PoseTolerance& tolerance = {});

/// Scores each of `recognizers` on cases [first, first + count) of a split with `other_views`
/// views each, all taught from the same pixels (the object the truth image box marks after the
/// detector chain, objectUnderRoi) and searched in the same frames, one recognizer after the
/// other on each frame. One score per recognizer, in their order.
std::vector<RecognitionScore> scoreRecognizers(const std::vector<Recognizer*>& recognizers,
                                               Split split, int first, int count,
                                               int other_views = 3,
                                               const PoseTolerance& tolerance = {});

/// `score` as it would have been had the method's detections below `min_score` been dropped
/// (its detection threshold raised to `min_score`; it keeps its best pose per search).
/// `tolerance` must be the one `score` was counted with. Its misses are not listed.
RecognitionScore withMinScore(const RecognitionScore& score, double min_score,
                              const PoseTolerance& tolerance = {});

/// The score as the table shapesense-eval prints.
std::string formatRecognitionScore(const std::string& label, const RecognitionScore& score);

/// One line per miss of `score`: where, what was reported, and what the method's check says of
/// the truth pose.
std::string formatRecognitionMisses(const RecognitionScore& score);

/// One line: recall by the objects' kind (found of required), kinds in name order.
std::string formatRecallByKind(const RecognitionScore& score);

}  // namespace shapesense::eval
