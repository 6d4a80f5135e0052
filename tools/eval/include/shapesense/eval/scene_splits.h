#pragma once
// The evaluation's scene distribution: synthetic scenes drawn from a wide range of rooms, camera
// poses, object mixes and sensor noise, with disjoint seeds for training, for choosing
// parameters (validation) and for reporting (test). Choose on validation; report test once per
// change, beside validation.

#include <cstdint>
#include <optional>
#include <string_view>

#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::eval {

enum class Split { kTrain, kValidation, kTest };

std::string_view formatSplit(Split split);
/// "train", "validation" (or "val") and "test".
std::optional<Split> parseSplit(std::string_view name);

/// One scene of the distribution and the frame of it that is scored.
struct EvalScene {
  synthetic::SceneParams params;
  std::uint64_t frame_index = 0;
  /// The scene holds curved objects (bowls, cups, tins, balls): spurious planes are counted
  /// against a looser requirement there.
  bool curved_clutter = false;
};

/// Scene `index` of a split: a pure function of (split, index); no two splits share a seed.
/// Half the scenes are plain (table, room, boxes of 3-60 cm, stacked and touching boxes,
/// books and boards, shelves: planar faces only) and half hold curved clutter besides (bowls,
/// cups, tins standing and lying, balls, lids, bins, columns, tori, smooth mounds). Across both:
/// 40% free-look camera poses (height 0.4-2 m, pitch 0-60 deg, rooms 3-7 m), 60% with up to +-2-10
/// deg of extra roll, and sensor noise 0.04-0.15 px, half with flying pixels, half with holes.
EvalScene evalScene(Split split, int index);

}  // namespace shapesense::eval
