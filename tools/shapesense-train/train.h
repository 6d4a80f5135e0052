// shapesense-train's train subcommand: one WaldBoost/LBP classifier per view of the bowl
// dataset, written as MODELS/bowl_<view>.json.
//
// Training is deterministic for a given dataset and seed, and resumable: the state at every
// negative-pool refill is checkpointed in MODELS/.checkpoints/ and a rerun continues from it.

#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace shapesense::train {

struct TrainOptions {
  std::filesystem::path data, out;
  std::uint64_t seed = 1;
  int stages = 100;
  double miss_rate = 0.05;
  std::size_t pool = 4000;
  int refill_every = 4;
  int window_width = 24;
  double margin = 0.125;
  double min_width_m = 0.08, max_width_m = 0.45;
  std::vector<std::string> views = {"top", "middle", "side"};
  int threads = 2;
  int jitter = 1;  // +-px shifts of positives at their pyramid level
};

/// Trains every view of `options.views` that has training bowls; returns the exit code.
int runTrain(const TrainOptions& options);

}  // namespace shapesense::train
