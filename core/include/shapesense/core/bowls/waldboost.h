#pragma once
// WaldBoost (Sochman & Matas, CVPR 2005) over LBP look-up-table weak classifiers.
//
// The strong classifier is a sequence of stages; stage t adds a weak classifier h_t (one LBP
// feature and a 256-entry table of real-valued votes, Real AdaBoost "domain partitioning")
// to the running score H_t and rejects the window when H_t < theta_t. Evaluation stops at the
// first rejection, so most background windows cost a few stages: that sequential decision is
// what WaldBoost adds to AdaBoost.
//
// Training (WaldBoostTrainer):
//  - weak learner: for every candidate feature, the class-weighted histograms W+ and W- of its
//    codes; the feature minimising Z = 2 * sum_k sqrt(W+_k W-_k) wins and its table is
//    0.5 * ln((W+_k + eps) / (W-_k + eps)), clipped;
//  - rejection threshold: Wald's SPRT rejects when the likelihood ratio p(H|+)/p(H|-) is small
//    enough to keep the miss rate below alpha. With sampled distributions we use its
//    operational form: theta_t is the highest threshold such that the positives rejected by
//    stages 1..t stay within alpha * t / T of the training positives (the miss-rate budget is
//    spread evenly over the stages); the negative distribution is then cut at theta_t, and
//    the fraction of negatives it removes is reported per stage;
//  - bootstrapping: rejected samples leave the training set; the negative pool is refilled
//    with windows the current classifier accepts (hard negatives), drawn from a caller's
//    source (bowl-free images), every `refill_every` stages and whenever the pool is empty;
//    training ends early when the source has no more hard negatives.
// Scores are integers in units of kWaldBoostScoreUnit so a model file round-trips exactly.

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/bowls/lbp.h"

namespace shapesense {

/// Score unit of the integer tables: a vote of 1000 is 1.0 in Real AdaBoost units.
inline constexpr double kWaldBoostScoreUnit = 1e-3;

struct WaldBoostStage {
  LbpFeature feature;
  /// Vote per LBP code, kWaldBoostScoreUnit units. The values fit 16 bits (the model files
  /// store them so); they are held as 32-bit so that the vector scan gathers them directly.
  std::array<std::int32_t, 256> lut{};
  /// Reject when the running score after this stage is < threshold. INT32_MIN = never.
  std::int32_t threshold = INT32_MIN;
  bool operator==(const WaldBoostStage&) const = default;
};

struct WaldBoostClassifier {
  int win_w = 0;  ///< window width in pixels
  int win_h = 0;  ///< window height in pixels
  std::vector<WaldBoostStage> stages;

  /// Evaluates the window whose top-left integral element is `origin`; `offsets[t]` are the
  /// stage features' offsets for the integral image's stride (see lbpOffsets). Returns true
  /// when every stage accepts; `score` gets the running score where evaluation stopped.
  bool evaluate(const std::int32_t* origin, const LbpOffsets* offsets, std::int32_t& score) const {
    std::int32_t h = 0;
    const std::size_t n = stages.size();
    for (std::size_t t = 0; t < n; ++t) {
      const WaldBoostStage& s = stages[t];
      h += s.lut[lbpCodeIntegral(origin, offsets[t])];
      if (h < s.threshold) {
        score = h;
        return false;
      }
    }
    score = h;
    return true;
  }

  /// The same with per-stage thresholds (from rejectionThresholds) in place of the stages' own.
  bool evaluate(const std::int32_t* origin, const LbpOffsets* offsets,
                const std::int32_t* thresholds, std::int32_t& score) const {
    std::int32_t h = 0;
    const std::size_t n = stages.size();
    for (std::size_t t = 0; t < n; ++t) {
      h += stages[t].lut[lbpCodeIntegral(origin, offsets[t])];
      if (h < thresholds[t]) {
        score = h;
        return false;
      }
    }
    score = h;
    return true;
  }

  /// The highest final score any window can reach: the sum of every table's largest vote.
  std::int64_t maxScore() const;

  /// Stage thresholds for a caller that keeps only windows whose final score is at least
  /// `min_final_score`: each stage's own threshold, raised to min_final_score minus the most
  /// the later stages can still add. A window these reject could never have been kept, so the
  /// kept set is exactly the same; background just stops earlier. Passing every stage
  /// implies a final score >= min_final_score.
  std::vector<std::int32_t> rejectionThresholds(std::int32_t min_final_score) const;

  /// The stage offsets for an integral image with `stride` elements per row.
  std::vector<LbpOffsets> offsetsFor(int stride) const;

  /// Convenience for one CV_8UC1 window of exactly win_w x win_h pixels.
  bool evaluateWindow(const cv::Mat& window8, std::int32_t& score) const;

  bool operator==(const WaldBoostClassifier&) const = default;
};

/// Parameters of WaldBoostTrainer.
struct WaldBoostTrainParams {
  int stages = 100;  ///< weak classifiers T. Default 100.
  double target_miss_rate =
      0.05;               ///< alpha: training positives all thresholds may reject. Default 0.05.
  int max_cell = 2;       ///< LBP cell sizes 1..max_cell pixels each way. Default 2 (seed).
  double lut_clip = 3.0;  ///< |vote| cap (Real AdaBoost units). Default 3.
  /// eps of the table, relative to 1/(samples): keeps empty bins finite. Default 0.5.
  double lut_smoothing = 0.5;
  std::size_t negative_pool = 4000;  ///< negatives drawn at each refill. Default 4000.
  /// Refill the negative pool every this many stages. Only the stage index decides (never
  /// the pool's size) so that a run resumed at a refill stage equals an uninterrupted one.
  /// Default 4.
  int refill_every = 4;
  /// Training stops early when a refill finds fewer hard negatives than this. Default 10.
  std::size_t min_negatives = 10;
};

/// Per-stage training statistics (for progress reports and tests).
struct WaldBoostStageStats {
  int stage = 0;                  ///< 1-based
  double z = 0.0;                 ///< the weak learner's Z
  double positives_kept = 1.0;    ///< fraction of the original positives still accepted
  double negatives_rejected = 0;  ///< fraction of the current pool this stage's threshold rejected
  std::size_t negative_pool = 0;  ///< negatives in the pool after the stage
  bool refilled = false;          ///< the pool was refilled before this stage
};

/// Supplies `count` negative windows (CV_8UC1, win_w x win_h) that `current` accepts, drawn
/// deterministically from `stage` (0-based index of the stage about to be trained); may
/// return fewer when the source is exhausted.
using NegativeSource = std::function<std::vector<cv::Mat>(const WaldBoostClassifier& current,
                                                          int stage, std::size_t count)>;

class WaldBoostTrainer {
 public:
  /// `start` may hold stages of an earlier run to resume from: positives are passed through
  /// it and the pool is refilled before the next stage, exactly as at a scheduled refill, so a
  /// resumed run equals an uninterrupted one when it resumes at a refill stage (see
  /// isRefillStage).
  WaldBoostTrainer(std::vector<cv::Mat> positives, WaldBoostClassifier start,
                   WaldBoostTrainParams params);

  /// Trains one stage. Returns false (and trains nothing) when done or out of negatives.
  bool trainStage(const NegativeSource& source, WaldBoostStageStats* stats = nullptr);

  /// True when stage index `stage` (0-based) starts with a scheduled refill.
  bool isRefillStage(int stage) const { return stage % params_.refill_every == 0; }

  const WaldBoostClassifier& classifier() const { return clf_; }
  std::size_t positivesLeft() const { return pos_.size(); }
  std::size_t negativesLeft() const { return neg_.size(); }

 private:
  struct Sample {
    std::vector<std::uint8_t> codes;  // one per candidate feature
    std::int32_t h = 0;               // running score
  };
  Sample makeSample(const cv::Mat& window8) const;
  void refill(const NegativeSource& source);

  WaldBoostTrainParams params_;
  WaldBoostClassifier clf_;
  std::vector<LbpFeature> features_;
  std::vector<Sample> pos_;
  std::vector<Sample> neg_;
  std::size_t initial_positives_ = 0;
  bool force_refill_ = true;  // the first stage of a run (fresh or resumed) starts with a refill
};

}  // namespace shapesense
