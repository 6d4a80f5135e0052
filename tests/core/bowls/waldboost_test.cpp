// WaldBoost on a toy separable problem: positives are windows with a bright disc at the centre
// of a noisy background, negatives are noise, half of them with the disc 4-5 px off centre
// (so that hard negatives remain for the bootstrapping). Checks that the rejection thresholds
// respect the target miss rate, that the classifier separates held-out data, and that a resumed run
// is identical.
#include <algorithm>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "shapesense/core/bowls/waldboost.h"

namespace shapesense {
namespace {

constexpr int kW = 12, kH = 12;

cv::Mat noise(cv::RNG& rng) {
  cv::Mat m(kH, kW, CV_8UC1);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

cv::Mat disc(cv::RNG& rng) {
  cv::Mat m = noise(rng);
  cv::Mat blob(kH, kW, CV_8UC1, cv::Scalar(0));
  cv::circle(blob, {kW / 2 + rng.uniform(-1, 2), kH / 2 + rng.uniform(-1, 2)}, 3, cv::Scalar(90),
             cv::FILLED);
  return m * 0.65 + blob;  // a faint disc: single features cannot separate it
}

cv::Mat negative(cv::RNG& rng) {
  cv::Mat m = noise(rng);
  if (rng.uniform(0, 2) == 1) {
    const int dx = rng.uniform(4, 6) * (rng.uniform(0, 2) ? 1 : -1), dy = rng.uniform(-5, 6);
    cv::Mat blob(kH, kW, CV_8UC1, cv::Scalar(0));
    cv::circle(blob, {kW / 2 + dx, kH / 2 + dy}, 3, cv::Scalar(90), cv::FILLED);
    m = m * 0.65 + blob;
  }
  return m;
}

std::vector<cv::Mat> positives(int n, std::uint64_t seed) {
  cv::RNG rng(seed);
  std::vector<cv::Mat> v;
  for (int i = 0; i < n; ++i) v.push_back(disc(rng));
  return v;
}

// Deterministic in (stage): noise windows the current classifier accepts.
NegativeSource noiseSource() {
  return [](const WaldBoostClassifier& clf, int stage, std::size_t count) {
    cv::RNG rng(1000 + stage);
    std::vector<cv::Mat> out;
    for (int tries = 0; tries < 100000 && out.size() < count; ++tries) {
      cv::Mat w = negative(rng);
      std::int32_t s;
      if (clf.evaluateWindow(w, s)) out.push_back(w);
    }
    return out;
  };
}

WaldBoostTrainParams toyParams() {
  WaldBoostTrainParams p;
  p.stages = 12;
  p.target_miss_rate = 0.1;
  p.negative_pool = 300;
  p.refill_every = 4;
  return p;
}

TEST(WaldBoost, ThresholdsRespectTargetMissRateAndSeparate) {
  const auto pos = positives(1500, 1);
  const auto params = toyParams();
  WaldBoostTrainer trainer(pos, WaldBoostClassifier{kW, kH, {}}, params);
  WaldBoostStageStats st;
  int stages = 0;
  while (trainer.trainStage(noiseSource(), &st)) {
    ++stages;
    // Budget spread evenly: after stage t at most alpha * t / T of the positives are lost.
    EXPECT_GE(st.positives_kept, 1.0 - params.target_miss_rate * stages / params.stages - 1e-12);
  }
  // Training ends early once the source has no hard negatives left (< min_negatives).
  ASSERT_GE(stages, 4);
  ASSERT_LE(stages, params.stages);
  const auto& clf = trainer.classifier();
  // Re-evaluating the training positives gives the same miss rate (<= alpha).
  int missed = 0;
  for (const auto& w : pos) {
    std::int32_t s;
    missed += clf.evaluateWindow(w, s) ? 0 : 1;
  }
  EXPECT_LE(missed, static_cast<int>(params.target_miss_rate * pos.size()));
  // Held-out: >= 85% of new discs pass every stage (the budget allows 10% training misses;
  // 5% more for generalisation), <= 3% of new negatives do (measured: 89.6% and 2%).
  int hits = 0, false_alarms = 0;
  cv::RNG rng(777);
  for (int i = 0; i < 500; ++i) {
    std::int32_t s;
    if (clf.evaluateWindow(disc(rng), s)) ++hits;
    if (clf.evaluateWindow(negative(rng), s)) ++false_alarms;
  }
  std::printf("held-out: %d/500 discs accepted, %d/500 negatives accepted\n", hits, false_alarms);
  EXPECT_GE(hits, 425);
  EXPECT_LE(false_alarms, 15);
}

TEST(WaldBoost, ResumedRunEqualsUninterruptedRun) {
  const auto pos = positives(1500, 1);
  const auto params = toyParams();
  WaldBoostTrainer full(pos, WaldBoostClassifier{kW, kH, {}}, params);
  while (full.trainStage(noiseSource())) {
  }
  WaldBoostTrainer first(pos, WaldBoostClassifier{kW, kH, {}}, params);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(first.trainStage(noiseSource()));
  ASSERT_TRUE(first.isRefillStage(4));
  WaldBoostTrainer resumed(pos, first.classifier(), params);
  while (resumed.trainStage(noiseSource())) {
  }
  EXPECT_GT(full.classifier().stages.size(), 4u);
  EXPECT_EQ(resumed.classifier(), full.classifier());
}

// The tightened thresholds (stop once the final score is out of reach) must keep exactly the
// windows that full evaluation followed by the final-score cut keeps, and stop earlier.
TEST(WaldBoost, TightenedThresholdsKeepExactlyTheWindowsThatReachTheFinalScore) {
  WaldBoostTrainer trainer(positives(1500, 1), WaldBoostClassifier{kW, kH, {}}, toyParams());
  while (trainer.trainStage(noiseSource())) {
  }
  const auto& clf = trainer.classifier();
  ASSERT_GE(clf.stages.size(), 4u);
  std::int64_t best = 0;
  for (const auto& s : clf.stages) best += *std::max_element(s.lut.begin(), s.lut.end());
  EXPECT_EQ(clf.maxScore(), best);

  cv::RNG rng(4242);
  std::vector<cv::Mat> windows;
  for (int i = 0; i < 400; ++i) windows.push_back(i % 2 ? disc(rng) : negative(rng));
  for (const std::int32_t min_final : {-1000000, 0, 1000, 3000, static_cast<std::int32_t>(best)}) {
    SCOPED_TRACE("min_final " + std::to_string(min_final));
    const auto thresholds = clf.rejectionThresholds(min_final);
    ASSERT_EQ(thresholds.size(), clf.stages.size());
    int kept = 0;
    for (const auto& w : windows) {
      const cv::Mat ii = lbpIntegral(w);
      const auto offsets = clf.offsetsFor(static_cast<int>(ii.step1()));
      std::int32_t full_score = 0, tight_score = 0;
      const bool full = clf.evaluate(ii.ptr<std::int32_t>(0), offsets.data(), full_score) &&
                        full_score >= min_final;
      const bool tight =
          clf.evaluate(ii.ptr<std::int32_t>(0), offsets.data(), thresholds.data(), tight_score);
      EXPECT_EQ(full, tight);
      if (tight) {
        EXPECT_EQ(tight_score, full_score);
      }
      kept += full;
    }
    bool raised = false;
    for (std::size_t t = 0; t < thresholds.size(); ++t) {
      EXPECT_GE(thresholds[t], clf.stages[t].threshold);
      raised = raised || thresholds[t] > clf.stages[t].threshold;
    }
    if (min_final == 1000) {
      EXPECT_GT(kept, 0);  // the comparison is not vacuous
    }
    if (min_final == best) {
      EXPECT_TRUE(raised);  // only a window scoring the maximum on every stage survives
    }
  }
}

}  // namespace
}  // namespace shapesense
