#pragma once
// A trained bowl classifier for one view and its model file (JSON, versioned).
//
// File format "shapesense-bowl-model", version 1 (one file per view, models/bowl_<view>.json):
// {
//   "format": "shapesense-bowl-model", "version": 1,
//   "view": "top" | "middle" | "side",          // synthetic view class it was trained on
//   "window": {"width": W, "height": H},          // classifier window, pixels
//   "object_margin": m,                           // the object box is the window shrunk by
//                                                 // m * W (resp. m * H) on each side
//   "object_width_m": [lo, hi],                   // physical width range of the object box
//                                                 // (the detector's depth gate)
//   "preprocess": {"near_m", "far_m", "low", "high", "fill_passes", "unfilled_value"},
//   "score_unit": 0.001,                          // scores/votes are integers in this unit
//   "lbp": {"bit_order": "clockwise-from-top-left", "compare": "neighbour >= centre"},
//   "training": {...},                            // free-form: how it was made (reproducibility)
//   "operating_point": {                          // optional: where the detector reports,
//     "score_threshold": t,                       //   chosen on validation data (see
//     "unverified_score_threshold": u,            //   BowlOperatingPoint); absent in a freshly
//     "chosen_on": "..."},                        //   trained model
//   "stages": [{"x", "y", "cw", "ch", "threshold" (int or null = never rejects),
//               "lut": [256 ints]}, ...]          // see waldboost.h
// }
// Loading is the only file I/O in core besides images; it throws std::runtime_error naming the
// file on any malformed content.

#include <filesystem>
#include <optional>
#include <string>

#include "shapesense/core/bowls/depth_preprocess.h"
#include "shapesense/core/bowls/waldboost.h"

namespace shapesense {

inline constexpr int kBowlModelVersion = 1;

/// Where the detector reports bowls, chosen on validation data and stated in the model files.
struct BowlOperatingPoint {
  /// Final classifier score (Real AdaBoost units plus the support bonus) a detection needs.
  double score_threshold = 0;
  /// Score a detection needs when the 3D check cannot settle it (keepBowlShaped).
  double unverified_score_threshold = 0;
  std::string chosen_on;  ///< the data and rule it was chosen by

  bool operator==(const BowlOperatingPoint&) const = default;
};

struct BowlViewModel {
  std::string view;  ///< "top", "middle" or "side"
  WaldBoostClassifier classifier;
  double object_margin = 0.125;      ///< see the file format
  double min_object_width_m = 0.08;  ///< depth gate, see the file format
  double max_object_width_m = 0.45;
  DepthPreprocessParams preprocess;
  std::string training_json = "{}";  ///< the "training" object, verbatim
  std::optional<BowlOperatingPoint> operating_point;

  bool operator==(const BowlViewModel& o) const {
    return view == o.view && classifier == o.classifier && object_margin == o.object_margin &&
           min_object_width_m == o.min_object_width_m && max_object_width_m == o.max_object_width_m;
  }
};

void saveBowlModel(const BowlViewModel& model, const std::filesystem::path& file);
BowlViewModel loadBowlModel(const std::filesystem::path& file);

}  // namespace shapesense
