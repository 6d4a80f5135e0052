#include "shapesense/eval/plane_eval.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include "shapesense/core/geometry/units.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"

namespace shapesense::eval {
namespace {

constexpr double kOverlap = 0.8;
constexpr double kMinTruthFraction = kPlaneSizeBinEdges[0];

int sizeBin(double fraction) {
  for (int b = kPlaneSizeBins - 1; b >= 0; --b)
    if (fraction >= kPlaneSizeBinEdges[b]) return b;
  return -1;
}

void countOutcomes(const SegCompScore& seg, double image_pixels, PlaneScore& s) {
  for (const auto& t : seg.truth) {
    if (!t.considered) continue;
    const int bin = sizeBin(t.pixels / image_pixels);
    if (bin < 0) continue;
    PlaneOutcomes& o = s.by_size[bin];
    switch (t.outcome) {
      case SegCompOutcome::kCorrect:
        ++o.correct;
        break;
      case SegCompOutcome::kOverSegmented:
        ++o.split;
        break;
      case SegCompOutcome::kUnderSegmented:
        ++o.merged;
        break;
      case SegCompOutcome::kNone:
        ++o.missed;
        break;
    }
  }
}

// Which kind of spurious plane (PlaneScore) one lying mostly on planar truth is, from the
// truth surfaces under its `all` pixels (`on_plane`: planar truth surface id -> pixels).
void countSpuriousKind(int all, const std::map<int, int>& on_plane,
                       const synthetic::TruthFrame& truth, PlaneScore& s) {
  constexpr double kMinSecondShare = 0.1;
  constexpr double kCreaseDeg = 60.0, kParallelDeg = 10.0, kCoplanarM = 0.005;
  std::pair<int, int> first{0, 0}, second{0, 0};  // (pixels, surface id)
  for (const auto& [surface, n] : on_plane) {
    if (n > first.first) {
      second = first;
      first = {n, surface};
    } else if (n > second.first) {
      second = {n, surface};
    }
  }
  const auto plane = [&](int id) -> const Eigen::Vector4d* {
    for (const auto& surface : truth.surfaces)
      if (surface.id == id) return &surface.plane;
    return nullptr;
  };
  const Eigen::Vector4d* a = plane(first.second);
  const Eigen::Vector4d* b = second.first >= kMinSecondShare * all ? plane(second.second) : nullptr;
  if (!a || !b) {
    ++s.spurious_other;
    return;
  }
  const double angle = angleDegOfCosine(a->head<3>().dot(b->head<3>()));
  if (angle >= kCreaseDeg) {
    ++s.spurious_across_crease;
  } else if (angle > kParallelDeg) {
    ++s.spurious_other;
  } else if (std::fabs((*a)[3] - (*b)[3]) <= kCoplanarM) {
    ++s.spurious_coplanar;
  } else {
    ++s.spurious_parallel;
  }
}

// A reported plane is spurious unless SegComp related it to a truth plane or >= T of its
// pixels lie on one planar truth surface (a real plane too small to be scored, or a part of
// one). Planes on curved surfaces have no planar truth pixels, so they are found by their own.
void countSpurious(const cv::Mat& labels, const SegCompScore& seg,
                   const synthetic::TruthFrame& truth, PlaneScore& s) {
  std::unordered_map<int, SegCompOutcome> related;
  for (const auto& f : seg.found) related[f.label] = f.outcome;
  std::vector<bool> curved(65536, false);
  for (const auto& surface : truth.surfaces)
    curved[surface.id] = surface.kind == synthetic::SurfaceKind::kCurved;
  struct Pixels {
    int all = 0, on_curved = 0;
    std::map<int, int> on_plane;  // planar truth surface -> pixels
  };
  std::map<int, Pixels> pixels;  // reported plane id -> its pixels
  for (int v = 0; v < labels.rows; ++v) {
    const auto* lp = labels.ptr<std::uint16_t>(v);
    const auto* tp = truth.surface_labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (!lp[u]) continue;
      Pixels& p = pixels[lp[u]];
      ++p.all;
      if (curved[tp[u]])
        ++p.on_curved;
      else if (tp[u])
        ++p.on_plane[tp[u]];
    }
  }
  for (const auto& [id, p] : pixels) {
    ++s.reported;
    const auto it = related.find(id);
    if (it != related.end() && it->second != SegCompOutcome::kNone) continue;
    int on_one_plane = 0;
    for (const auto& [surface, n] : p.on_plane) on_one_plane = std::max(on_one_plane, n);
    if (on_one_plane >= kOverlap * p.all) continue;
    ++s.spurious;
    if (2 * p.on_curved > p.all) {
      ++s.spurious_on_curved;
    } else {
      countSpuriousKind(p.all, p.on_plane, truth, s);
    }
  }
}

void planeErrors(const SegCompScore& seg, const cv::Mat& labels, const cv::Mat& planar,
                 const std::vector<DetectedPlane>& planes, const synthetic::TruthFrame& truth,
                 PlaneScore& s) {
  // The correct pairs: each correct truth region's found partner overlaps it by T both ways.
  std::map<std::pair<int, int>, int> overlap;
  std::unordered_map<int, int> found_pixels;
  for (int v = 0; v < planar.rows; ++v) {
    const auto* tp = planar.ptr<std::uint16_t>(v);
    const auto* fp = labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < planar.cols; ++u)
      if (tp[u] && fp[u]) {
        ++overlap[{tp[u], fp[u]}];
        ++found_pixels[fp[u]];
      }
  }
  std::unordered_map<int, int> correct_truth_pixels;
  for (const auto& t : seg.truth)
    if (t.outcome == SegCompOutcome::kCorrect) correct_truth_pixels[t.label] = t.pixels;
  for (const auto& [key, ov] : overlap) {
    const auto t = correct_truth_pixels.find(key.first);
    if (t == correct_truth_pixels.end()) continue;
    if (ov < kOverlap * t->second || ov < kOverlap * found_pixels[key.second]) continue;
    const auto fp =
        std::find_if(planes.begin(), planes.end(),
                     [found_id = key.second](const DetectedPlane& p) { return p.id == found_id; });
    const auto tp = std::find_if(
        truth.surfaces.begin(), truth.surfaces.end(),
        [truth_id = key.first](const synthetic::TruthSurface& x) { return x.id == truth_id; });
    if (fp == planes.end() || tp == truth.surfaces.end()) continue;
    const Eigen::Vector3d tn = tp->plane.head<3>();
    s.angle_deg.push_back(angleDegOfCosine(std::fabs(fp->normal.dot(tn))));
    s.dist_m.push_back(std::fabs(fp->d - tp->plane[3]));
    s.matches.emplace_back(key.first, key.second);
  }
}

}  // namespace

void PlaneOutcomes::add(const PlaneOutcomes& o) {
  correct += o.correct;
  split += o.split;
  merged += o.merged;
  missed += o.missed;
}

void PlaneScore::add(const PlaneScore& o) {
  frames += o.frames;
  truth_regions += o.truth_regions;
  correct += o.correct;
  for (int b = 0; b < kPlaneSizeBins; ++b) by_size[b].add(o.by_size[b]);
  reported += o.reported;
  spurious += o.spurious;
  spurious_on_curved += o.spurious_on_curved;
  spurious_across_crease += o.spurious_across_crease;
  spurious_parallel += o.spurious_parallel;
  spurious_coplanar += o.spurious_coplanar;
  spurious_other += o.spurious_other;
  angle_deg.insert(angle_deg.end(), o.angle_deg.begin(), o.angle_deg.end());
  dist_m.insert(dist_m.end(), o.dist_m.begin(), o.dist_m.end());
  matches.insert(matches.end(), o.matches.begin(), o.matches.end());
}

double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

cv::Mat planarTruth(const synthetic::TruthFrame& truth) {
  std::vector<bool> planar(65536, false);
  for (const auto& s : truth.surfaces) planar[s.id] = s.kind == synthetic::SurfaceKind::kPlane;
  cv::Mat t = truth.surface_labels.clone();
  for (int v = 0; v < t.rows; ++v) {
    auto* p = t.ptr<std::uint16_t>(v);
    for (int u = 0; u < t.cols; ++u)
      if (!planar[p[u]]) p[u] = 0;
  }
  return t;
}

PlaneScore scorePlanes(const cv::Mat& labels, const std::vector<DetectedPlane>& planes,
                       const synthetic::TruthFrame& truth) {
  CV_Assert(labels.type() == CV_16UC1 && labels.size() == truth.surface_labels.size());
  const cv::Mat planar = planarTruth(truth);
  const SegCompScore seg = scoreSegmentation(labels, planar, kOverlap, kMinTruthFraction);
  PlaneScore s;
  s.frames = 1;
  s.truth_regions = seg.truth_regions;
  s.correct = seg.correct;
  countOutcomes(seg, static_cast<double>(labels.total()), s);
  countSpurious(labels, seg, truth, s);
  planeErrors(seg, labels, planar, planes, truth, s);
  return s;
}

}  // namespace shapesense::eval
