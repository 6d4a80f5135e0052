#include "shapesense/core/segmentation/segmentation_scoring.h"

#include <algorithm>
#include <unordered_map>
#include <vector>

namespace shapesense {
namespace {

int labelAt(const cv::Mat& m, int v, int u) {
  return m.type() == CV_16UC1 ? m.ptr<std::uint16_t>(v)[u] : m.ptr<int>(v)[u];
}

// Region sizes and the overlap of every truth region t with every found region f, over the
// pixels with a truth label; labels compacted to dense indices in order of appearance.
struct OverlapTable {
  std::vector<int> t_size, f_size;
  std::vector<int> t_label, f_label;
  std::vector<int> overlap;  // [t * nf + f]
  long labelled = 0;         // pixels with a truth label

  int nt() const { return static_cast<int>(t_size.size()); }
  int nf() const { return static_cast<int>(f_size.size()); }
  int at(int t, int f) const { return overlap[static_cast<std::size_t>(t) * nf() + f]; }
};

OverlapTable overlapTable(const cv::Mat& found_labels, const cv::Mat& truth_labels) {
  OverlapTable table;
  std::unordered_map<int, int> t_index, f_index;
  std::unordered_map<long long, int> overlap_map;
  for (int v = 0; v < truth_labels.rows; ++v) {
    for (int u = 0; u < truth_labels.cols; ++u) {
      const int t = labelAt(truth_labels, v, u);
      if (t == 0) continue;
      ++table.labelled;
      auto [ti, tnew] = t_index.try_emplace(t, static_cast<int>(table.t_size.size()));
      if (tnew) {
        table.t_size.push_back(0);
        table.t_label.push_back(t);
      }
      ++table.t_size[ti->second];
      const int f = labelAt(found_labels, v, u);
      if (f == 0) continue;
      auto [fi, fnew] = f_index.try_emplace(f, static_cast<int>(table.f_size.size()));
      if (fnew) {
        table.f_size.push_back(0);
        table.f_label.push_back(f);
      }
      ++table.f_size[fi->second];
      ++overlap_map[(static_cast<long long>(ti->second) << 32) | fi->second];
    }
  }
  const int nf = table.nf();
  table.overlap.assign(static_cast<std::size_t>(table.nt()) * nf, 0);
  for (const auto& [key, count] : overlap_map)
    table.overlap[(key >> 32) * nf + (key & 0xffffffff)] = count;
  return table;
}

// What each region was classified as (SegCompOutcome: 0 nothing yet, 1 correct, 2 over-, 3
// under-segmented), and which truth regions are large enough to count.
struct Classification {
  std::vector<char> considered, t_rel, f_rel;
};

// Correct detections: a found region and a truth region that each overlap the other by T.
void classifyCorrect(const OverlapTable& o, double T, Classification& c, SegCompScore& s) {
  for (int t = 0; t < o.nt(); ++t) {
    if (!c.considered[t]) continue;
    for (int f = 0; f < o.nf(); ++f) {
      const int ov = o.at(t, f);
      if (ov >= T * o.t_size[t] && ov >= T * o.f_size[f]) {
        ++s.correct;
        c.t_rel[t] = 1;
        c.f_rel[f] = 1;
        break;
      }
    }
  }
}

// Over-segmentation: a truth region made of two or more found regions.
void classifyOverSegmented(const OverlapTable& o, double T, Classification& c, SegCompScore& s) {
  for (int t = 0; t < o.nt(); ++t) {
    if (!c.considered[t] || c.t_rel[t]) continue;
    long sum = 0;
    int parts = 0;
    for (int f = 0; f < o.nf(); ++f) {
      if (c.f_rel[f]) continue;
      const int ov = o.at(t, f);
      if (ov > 0 && ov >= T * o.f_size[f]) {
        sum += ov;
        ++parts;
      }
    }
    if (parts >= 2 && sum >= T * o.t_size[t]) {
      ++s.over_segmented;
      c.t_rel[t] = 2;
      for (int f = 0; f < o.nf(); ++f) {
        const int ov = o.at(t, f);
        if (!c.f_rel[f] && ov > 0 && ov >= T * o.f_size[f]) c.f_rel[f] = 2;
      }
    }
  }
}

// Under-segmentation: a found region made of two or more truth regions.
void classifyUnderSegmented(const OverlapTable& o, double T, Classification& c, SegCompScore& s) {
  for (int f = 0; f < o.nf(); ++f) {
    if (c.f_rel[f]) continue;
    long sum = 0;
    int parts = 0;
    for (int t = 0; t < o.nt(); ++t) {
      if (!c.considered[t] || c.t_rel[t]) continue;
      const int ov = o.at(t, f);
      if (ov > 0 && ov >= T * o.t_size[t]) {
        sum += ov;
        ++parts;
      }
    }
    if (parts >= 2 && sum >= T * o.f_size[f]) {
      c.f_rel[f] = 3;
      for (int t = 0; t < o.nt(); ++t) {
        const int ov = o.at(t, f);
        if (c.considered[t] && !c.t_rel[t] && ov > 0 && ov >= T * o.t_size[t]) {
          c.t_rel[t] = 3;
          ++s.under_segmented;
        }
      }
    }
  }
}

// Each found region scores the truth region it overlaps most.
double pixelAccuracy(const OverlapTable& o) {
  long good = 0;
  for (int f = 0; f < o.nf(); ++f) {
    int best = 0;
    for (int t = 0; t < o.nt(); ++t) best = std::max(best, o.at(t, f));
    good += best;
  }
  return o.labelled > 0 ? static_cast<double>(good) / o.labelled : 0.0;
}

}  // namespace

SegCompScore scoreSegmentation(const cv::Mat& found_labels, const cv::Mat& truth_labels, double T,
                               double min_truth_fraction) {
  CV_Assert(found_labels.size() == truth_labels.size());
  CV_Assert(found_labels.type() == CV_16UC1 || found_labels.type() == CV_32SC1);
  CV_Assert(truth_labels.type() == CV_16UC1 || truth_labels.type() == CV_32SC1);
  const OverlapTable o = overlapTable(found_labels, truth_labels);
  const int nt = o.nt(), nf = o.nf();
  SegCompScore s;
  s.found_regions = nf;
  const double min_px = min_truth_fraction * truth_labels.rows * truth_labels.cols;
  Classification c{std::vector<char>(nt), std::vector<char>(nt, 0), std::vector<char>(nf, 0)};
  for (int t = 0; t < nt; ++t) c.considered[t] = o.t_size[t] >= min_px;
  for (int t = 0; t < nt; ++t) s.truth_regions += c.considered[t];
  classifyCorrect(o, T, c, s);
  classifyOverSegmented(o, T, c, s);
  classifyUnderSegmented(o, T, c, s);
  for (int t = 0; t < nt; ++t) s.missed += c.considered[t] && !c.t_rel[t];
  for (int f = 0; f < nf; ++f) s.noise += !c.f_rel[f];
  s.correct_fraction = s.truth_regions > 0 ? static_cast<double>(s.correct) / s.truth_regions : 0.0;
  s.pixel_accuracy = pixelAccuracy(o);
  for (int t = 0; t < nt; ++t)
    s.truth.push_back(
        {o.t_label[t], o.t_size[t], c.considered[t] != 0, static_cast<SegCompOutcome>(c.t_rel[t])});
  for (int f = 0; f < nf; ++f)
    s.found.push_back({o.f_label[f], o.f_size[f], static_cast<SegCompOutcome>(c.f_rel[f])});
  return s;
}

}  // namespace shapesense
