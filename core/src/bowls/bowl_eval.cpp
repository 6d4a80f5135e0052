#include "shapesense/core/bowls/bowl_eval.h"

#include <algorithm>

namespace shapesense {

bool isTinyOrSparseBowl(const cv::Rect& box, std::size_t pixel_count) {
  return box.width < 20 || box.height < 12 || static_cast<double>(pixel_count) < 0.25 * box.area();
}

bool isDifficultBowl(const cv::Rect& box, std::size_t pixel_count, double visible_fraction) {
  return isTinyOrSparseBowl(box, pixel_count) || visible_fraction < kMinVisibleBowlFraction;
}

BowlEvalResult evaluateBowlDetections(const std::vector<BowlEvalFrame>& frames, double iou,
                                      double fppi) {
  BowlEvalResult r;
  r.frames = static_cast<int>(frames.size());
  struct Scored {
    double score;
    int label;  // 1 TP, 0 FP, -1 ignored
  };
  std::vector<Scored> all;
  for (const auto& f : frames) {
    for (const auto& t : f.truth) r.positives += t.difficult ? 0 : 1;
    std::vector<const BowlDetection*> dets;
    for (const auto& d : f.detections) dets.push_back(&d);
    std::stable_sort(dets.begin(), dets.end(),
                     [](auto* a, auto* b) { return a->score > b->score; });
    std::vector<bool> used(f.truth.size(), false);
    for (const auto* d : dets) {
      double best = 0;
      int bi = -1;
      for (std::size_t i = 0; i < f.truth.size(); ++i) {
        if (used[i] && !f.truth[i].difficult) continue;
        const double o = boxIoU(d->box, f.truth[i].box);
        if (o > best) {
          best = o;
          bi = static_cast<int>(i);
        }
      }
      if (bi >= 0 && best >= iou) {
        if (f.truth[bi].difficult) {
          all.push_back({d->score, -1});
        } else {
          used[bi] = true;
          all.push_back({d->score, 1});
        }
      } else {
        all.push_back({d->score, 0});
      }
    }
  }
  std::stable_sort(all.begin(), all.end(),
                   [](const Scored& a, const Scored& b) { return a.score > b.score; });
  std::vector<double> prec, rec;
  int tp = 0, fp = 0;
  double best_recall_within_budget = 0.0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (all[i].label == 1) ++tp;
    if (all[i].label == 0) ++fp;
    if (all[i].label == -1) continue;
    // Only a threshold between distinct scores is a real operating point.
    const bool last_of_score = i + 1 == all.size() || all[i + 1].score != all[i].score;
    if (!last_of_score) continue;
    const double recall = r.positives ? static_cast<double>(tp) / r.positives : 0.0;
    prec.push_back(static_cast<double>(tp) / std::max(1, tp + fp));
    rec.push_back(recall);
    if (r.frames > 0 && fp <= fppi * r.frames)
      best_recall_within_budget = std::max(best_recall_within_budget, recall);
  }
  r.true_positives = tp;
  r.false_positives = fp;
  r.max_recall = r.positives ? static_cast<double>(tp) / r.positives : 0.0;
  r.miss_rate_at_fppi = 1.0 - best_recall_within_budget;
  // All-point interpolation: precision envelope, summed over recall steps.
  for (int i = static_cast<int>(prec.size()) - 2; i >= 0; --i)
    prec[i] = std::max(prec[i], prec[i + 1]);
  double prev_recall = 0.0;
  for (std::size_t i = 0; i < prec.size(); ++i) {
    r.ap += (rec[i] - prev_recall) * prec[i];
    prev_recall = rec[i];
  }
  return r;
}

}  // namespace shapesense
