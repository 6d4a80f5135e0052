#include "shapesense/core/segmentation/segmentation_scoring.h"

#include <algorithm>
#include <unordered_map>
#include <vector>

namespace shapesense {
namespace {

int labelAt(const cv::Mat& m, int v, int u) {
  return m.type() == CV_16UC1 ? m.ptr<std::uint16_t>(v)[u] : m.ptr<int>(v)[u];
}

}  // namespace

SegCompScore scoreSegmentation(const cv::Mat& found_labels, const cv::Mat& truth_labels, double T,
                               double min_truth_fraction) {
  CV_Assert(found_labels.size() == truth_labels.size());
  CV_Assert(found_labels.type() == CV_16UC1 || found_labels.type() == CV_32SC1);
  CV_Assert(truth_labels.type() == CV_16UC1 || truth_labels.type() == CV_32SC1);
  // Compact both label sets to dense indices.
  std::unordered_map<int, int> t_index, f_index;
  std::vector<int> t_size, f_size;
  std::vector<std::pair<int, int>> pairs;  // (t, f) per scored pixel with f != 0
  long labelled = 0;
  std::unordered_map<long long, int> overlap_map;
  for (int v = 0; v < truth_labels.rows; ++v) {
    for (int u = 0; u < truth_labels.cols; ++u) {
      const int t = labelAt(truth_labels, v, u);
      if (t == 0) continue;
      ++labelled;
      auto [ti, tnew] = t_index.try_emplace(t, static_cast<int>(t_size.size()));
      if (tnew) t_size.push_back(0);
      ++t_size[ti->second];
      const int f = labelAt(found_labels, v, u);
      if (f == 0) continue;
      auto [fi, fnew] = f_index.try_emplace(f, static_cast<int>(f_size.size()));
      if (fnew) f_size.push_back(0);
      ++f_size[fi->second];
      ++overlap_map[(static_cast<long long>(ti->second) << 32) | fi->second];
    }
  }
  const int nt = static_cast<int>(t_size.size()), nf = static_cast<int>(f_size.size());
  std::vector<int> O(static_cast<std::size_t>(nt) * nf, 0);
  for (const auto& [key, count] : overlap_map) O[(key >> 32) * nf + (key & 0xffffffff)] = count;

  SegCompScore s;
  s.found_regions = nf;
  const double min_px = min_truth_fraction * truth_labels.rows * truth_labels.cols;
  std::vector<char> considered(nt), t_rel(nt, 0), f_rel(nf, 0);
  for (int t = 0; t < nt; ++t) considered[t] = t_size[t] >= min_px;
  for (int t = 0; t < nt; ++t) s.truth_regions += considered[t];

  // Correct detections.
  for (int t = 0; t < nt; ++t) {
    if (!considered[t]) continue;
    for (int f = 0; f < nf; ++f) {
      const int o = O[t * nf + f];
      if (o >= T * t_size[t] && o >= T * f_size[f]) {
        ++s.correct;
        t_rel[t] = 1;
        f_rel[f] = 1;
        break;
      }
    }
  }
  // Over-segmentation.
  for (int t = 0; t < nt; ++t) {
    if (!considered[t] || t_rel[t]) continue;
    long sum = 0;
    int parts = 0;
    for (int f = 0; f < nf; ++f) {
      if (f_rel[f]) continue;
      const int o = O[t * nf + f];
      if (o > 0 && o >= T * f_size[f]) {
        sum += o;
        ++parts;
      }
    }
    if (parts >= 2 && sum >= T * t_size[t]) {
      ++s.over_segmented;
      t_rel[t] = 2;
      for (int f = 0; f < nf; ++f) {
        const int o = O[t * nf + f];
        if (!f_rel[f] && o > 0 && o >= T * f_size[f]) f_rel[f] = 2;
      }
    }
  }
  // Under-segmentation.
  for (int f = 0; f < nf; ++f) {
    if (f_rel[f]) continue;
    long sum = 0;
    int parts = 0;
    for (int t = 0; t < nt; ++t) {
      if (!considered[t] || t_rel[t]) continue;
      const int o = O[t * nf + f];
      if (o > 0 && o >= T * t_size[t]) {
        sum += o;
        ++parts;
      }
    }
    if (parts >= 2 && sum >= T * f_size[f]) {
      f_rel[f] = 3;
      for (int t = 0; t < nt; ++t) {
        const int o = O[t * nf + f];
        if (considered[t] && !t_rel[t] && o > 0 && o >= T * t_size[t]) {
          t_rel[t] = 3;
          ++s.under_segmented;
        }
      }
    }
  }
  for (int t = 0; t < nt; ++t) s.missed += considered[t] && !t_rel[t];
  for (int f = 0; f < nf; ++f) s.noise += !f_rel[f];
  s.correct_fraction = s.truth_regions > 0 ? static_cast<double>(s.correct) / s.truth_regions : 0.0;

  long good = 0;
  for (int f = 0; f < nf; ++f) {
    int best = 0;
    for (int t = 0; t < nt; ++t) best = std::max(best, O[t * nf + f]);
    good += best;
  }
  s.pixel_accuracy = labelled > 0 ? static_cast<double>(good) / labelled : 0.0;
  return s;
}

}  // namespace shapesense
