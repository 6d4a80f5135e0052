#include "shapesense/core/bowls/waldboost.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace shapesense {

std::vector<LbpOffsets> WaldBoostClassifier::offsetsFor(int stride) const {
  std::vector<LbpOffsets> out;
  out.reserve(stages.size());
  for (const auto& s : stages) out.push_back(lbpOffsets(s.feature, stride));
  return out;
}

bool WaldBoostClassifier::evaluateWindow(const cv::Mat& window8, std::int32_t& score) const {
  CV_Assert(window8.type() == CV_8UC1 && window8.cols == win_w && window8.rows == win_h);
  const cv::Mat ii = lbpIntegral(window8);
  const auto off = offsetsFor(static_cast<int>(ii.step1()));
  return evaluate(ii.ptr<std::int32_t>(0), off.data(), score);
}

std::int64_t WaldBoostClassifier::maxScore() const {
  std::int64_t total = 0;
  for (const auto& s : stages) total += *std::max_element(s.lut.begin(), s.lut.end());
  return total;
}

std::vector<std::int32_t> WaldBoostClassifier::rejectionThresholds(
    std::int32_t min_final_score) const {
  std::vector<std::int32_t> out(stages.size());
  std::int64_t still_addable = 0;  // the most stages t+1..T-1 can add
  for (std::size_t t = stages.size(); t-- > 0;) {
    const std::int64_t bound = static_cast<std::int64_t>(min_final_score) - still_addable;
    const std::int64_t own = stages[t].threshold;
    out[t] = static_cast<std::int32_t>(
        std::clamp<std::int64_t>(std::max(own, bound), INT32_MIN, INT32_MAX));
    still_addable += *std::max_element(stages[t].lut.begin(), stages[t].lut.end());
  }
  return out;
}

WaldBoostTrainer::WaldBoostTrainer(std::vector<cv::Mat> positives, WaldBoostClassifier start,
                                   WaldBoostTrainParams params)
    : params_(params), clf_(std::move(start)) {
  if (clf_.win_w < 3 || clf_.win_h < 3)
    throw std::invalid_argument("WaldBoostTrainer: window too small");
  if (params_.refill_every < 1) throw std::invalid_argument("WaldBoostTrainer: refill_every < 1");
  features_ = enumerateLbpFeatures(clf_.win_w, clf_.win_h, params_.max_cell);
  initial_positives_ = positives.size();
  // Pass the positives through the stages we resume from: those they reject are gone, the
  // others carry their running score (the boosting weights follow from it).
  for (const auto& w : positives) {
    Sample s = makeSample(w);
    std::int32_t score = 0;
    if (clf_.evaluateWindow(w, score)) {
      s.h = score;
      pos_.push_back(std::move(s));
    }
  }
}

WaldBoostTrainer::Sample WaldBoostTrainer::makeSample(const cv::Mat& window8) const {
  CV_Assert(window8.type() == CV_8UC1 && window8.cols == clf_.win_w && window8.rows == clf_.win_h);
  const cv::Mat ii = lbpIntegral(window8);
  const int stride = static_cast<int>(ii.step1());
  Sample s;
  s.codes.resize(features_.size());
  const std::int32_t* origin = ii.ptr<std::int32_t>(0);
  for (std::size_t f = 0; f < features_.size(); ++f)
    s.codes[f] = lbpCodeIntegral(origin, lbpOffsets(features_[f], stride));
  return s;
}

void WaldBoostTrainer::refill(const NegativeSource& source) {
  const int stage = static_cast<int>(clf_.stages.size());
  const auto windows = source(clf_, stage, params_.negative_pool);
  neg_.clear();
  neg_.reserve(windows.size());
  for (const auto& w : windows) {
    Sample s = makeSample(w);
    std::int32_t score = 0;
    // The source promises accepted windows; evaluate anyway for the running score.
    if (clf_.evaluateWindow(w, score)) {
      s.h = score;
      neg_.push_back(std::move(s));
    }
  }
}

bool WaldBoostTrainer::trainStage(const NegativeSource& source, WaldBoostStageStats* stats) {
  const int t = static_cast<int>(clf_.stages.size());
  if (t >= params_.stages || pos_.empty()) return false;
  bool refilled = false;
  // Refill on schedule, and whenever the pool ran dry (both depend only on the classifier and
  // the stage, so a resumed run still replays an uninterrupted one exactly).
  if (force_refill_ || isRefillStage(t) || neg_.empty()) {
    refill(source);
    force_refill_ = false;
    refilled = true;
  }
  if (neg_.size() < params_.min_negatives) return false;  // the source found no more hard negatives

  // Boosting weights w = exp(-y H), each class normalised to 1/2 so that the pool sizes do
  // not bias the weak learner (the bootstrapped pool is refilled to a fixed size anyway).
  auto weights = [](const std::vector<Sample>& v, double sign) {
    std::vector<double> w(v.size());
    double sum = 0;
    for (std::size_t i = 0; i < v.size(); ++i)
      sum += (w[i] = std::exp(-sign * v[i].h * kWaldBoostScoreUnit));
    for (double& x : w) x *= 0.5 / sum;
    return w;
  };
  const std::vector<double> wp = weights(pos_, 1.0), wn = weights(neg_, -1.0);

  // Weak learner: the feature of least Z.
  double best_z = std::numeric_limits<double>::infinity();
  std::size_t best_f = 0;
  std::array<double, 256> hp{}, hn{}, best_hp{}, best_hn{};
  for (std::size_t f = 0; f < features_.size(); ++f) {
    hp.fill(0.0);
    hn.fill(0.0);
    for (std::size_t i = 0; i < pos_.size(); ++i) hp[pos_[i].codes[f]] += wp[i];
    for (std::size_t i = 0; i < neg_.size(); ++i) hn[neg_[i].codes[f]] += wn[i];
    double z = 0;
    for (int k = 0; k < 256; ++k) z += std::sqrt(hp[k] * hn[k]);
    z *= 2.0;
    if (z < best_z) {
      best_z = z;
      best_f = f;
      best_hp = hp;
      best_hn = hn;
    }
  }
  WaldBoostStage stage;
  stage.feature = features_[best_f];
  const double eps = params_.lut_smoothing / static_cast<double>(pos_.size() + neg_.size());
  for (int k = 0; k < 256; ++k) {
    const double v = std::clamp(0.5 * std::log((best_hp[k] + eps) / (best_hn[k] + eps)),
                                -params_.lut_clip, params_.lut_clip);
    stage.lut[k] = static_cast<std::int16_t>(std::lround(v / kWaldBoostScoreUnit));
  }
  for (auto& s : pos_) s.h += stage.lut[s.codes[best_f]];
  for (auto& s : neg_) s.h += stage.lut[s.codes[best_f]];

  // Rejection threshold from the positive score distribution and the miss-rate budget.
  const std::size_t budget = static_cast<std::size_t>(
      std::floor(params_.target_miss_rate * static_cast<double>(initial_positives_) * (t + 1) /
                 params_.stages));
  const std::size_t already = initial_positives_ - pos_.size();
  const std::size_t allowed = budget > already ? budget - already : 0;
  std::vector<std::int32_t> ps(pos_.size());
  for (std::size_t i = 0; i < pos_.size(); ++i) ps[i] = pos_[i].h;
  std::sort(ps.begin(), ps.end());
  // Rejecting "h < ps[allowed]" removes at most `allowed` positives (fewer on ties).
  stage.threshold = allowed < ps.size() ? ps[allowed] : ps.back();
  if (t + 1 == params_.stages) stage.threshold = INT32_MIN;  // the last stage only scores
  const std::size_t neg_before = neg_.size();
  std::erase_if(pos_, [&](const Sample& s) { return s.h < stage.threshold; });
  std::erase_if(neg_, [&](const Sample& s) { return s.h < stage.threshold; });
  clf_.stages.push_back(stage);

  if (stats) {
    stats->stage = t + 1;
    stats->z = best_z;
    stats->positives_kept =
        static_cast<double>(pos_.size()) / std::max<std::size_t>(1, initial_positives_);
    stats->negatives_rejected =
        1.0 - static_cast<double>(neg_.size()) / std::max<std::size_t>(1, neg_before);
    stats->negative_pool = neg_.size();
    stats->refilled = refilled;
  }
  return true;
}

}  // namespace shapesense
