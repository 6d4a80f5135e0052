#pragma once
// Scoring helpers shared by the plane tests and the planes benchmark (header-only, test side):
// SegComp correct detection of truth planar surfaces and the plane errors of matched regions.

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/planes/planes.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::planetest {

struct PlaneScore {
  int truth_regions = 0;          ///< truth planar surfaces >= 0.5% of the image
  int correct = 0;                ///< SegComp correct detections at T = 0.8
  std::vector<double> angle_deg;  ///< per correctly detected truth plane
  std::vector<double> dist_m;
  std::vector<std::pair<int, int>> matches;  ///< (truth surface id, found id) of correct pairs

  void add(const PlaneScore& o) {
    truth_regions += o.truth_regions;
    correct += o.correct;
    angle_deg.insert(angle_deg.end(), o.angle_deg.begin(), o.angle_deg.end());
    dist_m.insert(dist_m.end(), o.dist_m.begin(), o.dist_m.end());
    matches.insert(matches.end(), o.matches.begin(), o.matches.end());
  }
  double correctFraction() const { return truth_regions ? double(correct) / truth_regions : 0.0; }
};

inline double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// truth.surface_labels restricted to planar surfaces.
inline cv::Mat planarTruth(const synthetic::TruthFrame& truth) {
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

/// Scores `found` (labels + planes whose ids index them) against the planar truth.
inline PlaneScore scorePlanes(const cv::Mat& labels, const std::vector<DetectedPlane>& planes,
                              const synthetic::TruthFrame& truth) {
  const cv::Mat t = planarTruth(truth);
  const SegCompScore seg = scoreSegmentation(labels, t, 0.8, 0.005);
  PlaneScore s;
  s.truth_regions = seg.truth_regions;
  s.correct = seg.correct;
  // Overlaps over truth pixels, for the plane errors of correct pairs.
  std::map<int, long> tsize, fsize;
  std::map<std::pair<int, int>, long> ov;
  for (int v = 0; v < t.rows; ++v) {
    const auto* tp = t.ptr<std::uint16_t>(v);
    const auto* fp = labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < t.cols; ++u) {
      if (!tp[u]) continue;
      ++tsize[tp[u]];
      if (fp[u]) {
        ++fsize[fp[u]];
        ++ov[{tp[u], fp[u]}];
      }
    }
  }
  const double min_px = 0.005 * t.rows * t.cols;
  for (const auto& [key, o] : ov) {
    const auto [tid, fid] = key;
    if (tsize[tid] < min_px || o < 0.8 * tsize[tid] || o < 0.8 * fsize[fid]) continue;
    const auto fp = std::find_if(planes.begin(), planes.end(),
                                 [&](const DetectedPlane& p) { return p.id == fid; });
    const auto tp = std::find_if(truth.surfaces.begin(), truth.surfaces.end(),
                                 [&](const synthetic::TruthSurface& x) { return x.id == tid; });
    if (fp == planes.end() || tp == truth.surfaces.end()) continue;
    const Eigen::Vector3d tn = tp->plane.head<3>();
    s.angle_deg.push_back(std::acos(std::clamp(std::fabs(fp->normal.dot(tn)), 0.0, 1.0)) * 180.0 /
                          M_PI);
    s.dist_m.push_back(std::fabs(fp->d - tp->plane[3]));
    s.matches.emplace_back(tid, fid);
  }
  return s;
}

}  // namespace shapesense::planetest
