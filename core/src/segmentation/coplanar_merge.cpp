#include "segmentation/coplanar_merge.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "shapesense/core/geometry/union_find.h"

namespace shapesense::segmentation {

namespace {

// Moments of the points (u, v, w = 1/z) of a region, for the least-squares fit of
// w = a u + b v + c. Additive, so the fit of any union is O(1) from its parts' sums. (Not
// geometry's PlaneMoments: that fits the total-least-squares plane of 3D points, a different
// model.)
struct InverseDepthMoments {
  // n u v w uu uv vv uw vw ww
  std::array<double, 10> s{};

  double count() const { return s[0]; }
  InverseDepthMoments& operator+=(const InverseDepthMoments& o) {
    for (int k = 0; k < 10; ++k) s[k] += o.s[k];
    return *this;
  }
  /// RMS residual (1/m) of the least-squares plane; 1e9 when the fit is singular.
  double rms() const {
    const cv::Matx33d A(s[4], s[5], s[1], s[5], s[6], s[2], s[1], s[2], s[0]);
    const cv::Vec3d b(s[7], s[8], s[3]);
    cv::Vec3d x;
    if (!cv::solve(A, b, x, cv::DECOMP_CHOLESKY)) return 1e9;
    return std::sqrt(std::max(0.0, s[9] - x.dot(b)) / s[0]);
  }
};

// Row sums of one run of a region's pixels (one row, so v is constant).
struct RowRun {
  double c = 0, su = 0, suu = 0, sw = 0, suw = 0, sww = 0;

  void add(double fu, double iw) {
    c += 1;
    su += fu;
    suu += fu * fu;
    sw += iw;
    suw += fu * iw;
    sww += iw * iw;
  }
  void flushInto(InverseDepthMoments& m, double fv) {
    auto& a = m.s;
    a[0] += c;
    a[1] += su;
    a[2] += fv * c;
    a[3] += sw;
    a[4] += suu;
    a[5] += fv * su;
    a[6] += fv * fv * c;
    a[7] += suw;
    a[8] += fv * sw;
    a[9] += sww;
    *this = RowRun{};
  }
};

// The moments of every region's core (low edge strength: flooded edge bands hold mixed pixels),
// in image coordinates centred on the image. Row-local sums over runs of one label are flushed
// into the region's moments when the label changes: no per-pixel read-modify-write of a
// region's moments in memory.
std::vector<InverseDepthMoments> regionMoments(const cv::Mat& labels, int n, const cv::Mat& edges,
                                               const cv::Mat& depth, int max_edge) {
  std::vector<InverseDepthMoments> m(n);
  const double uc = labels.cols * 0.5, vc = labels.rows * 0.5;
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const auto* d = depth.ptr<std::uint16_t>(v);
    const auto* e = edges.ptr<std::uint8_t>(v);
    const double fv = v - vc;
    int cur = 0;
    RowRun run;
    auto flush = [&] {
      if (cur > 0 && run.c != 0) run.flushInto(m[cur], fv);
    };
    for (int u = 0; u < labels.cols; ++u) {
      if (l[u] <= 0 || d[u] == 0 || e[u] > max_edge) continue;
      if (l[u] != cur) {
        flush();
        cur = l[u];
      }
      run.add(u - uc, 1000.0f / static_cast<float>(d[u]));
    }
    flush();
  }
  return m;
}

// Merges, best pair first, the candidates whose union fits within `t`; parent[j] = i for each
// region j merged into i.
void mergeBestPairs(std::vector<InverseDepthMoments>& m, std::vector<int> cand, double t,
                    std::vector<int>& parent) {
  for (;;) {
    double best = t;
    int bi = -1, bj = -1;
    for (std::size_t a = 0; a < cand.size(); ++a) {
      for (std::size_t b = a + 1; b < cand.size(); ++b) {
        InverseDepthMoments u = m[cand[a]];
        u += m[cand[b]];
        const double r = u.rms();
        if (r <= best) {
          best = r;
          bi = static_cast<int>(a);
          bj = static_cast<int>(b);
        }
      }
    }
    if (bi < 0) break;
    const int i = cand[bi], j = cand[bj];
    m[i] += m[j];
    parent[j] = i;
    cand.erase(cand.begin() + bj);
  }
}

}  // namespace

void mergeCoplanarRegions(cv::Mat& labels, int max_label, const cv::Mat& edges,
                          const WorkingImage& w, const RegionParams& rp) {
  if (!rp.merge_coplanar) return;
  const int n = max_label + 1;
  if (n <= 2) return;
  std::vector<InverseDepthMoments> m = regionMoments(labels, n, edges, w.depth, rp.marker_max_edge);
  const double t = rp.coplanar_rms_steps * inverseDepthStep(rp.noise);
  const double min_n = static_cast<double>(rp.coplanar_min_px) / (w.ds * w.ds);
  std::vector<int> cand;
  for (int i = 1; i < n; ++i) {
    if (m[i].count() > 0 && m[i].count() >= min_n && m[i].rms() <= t) cand.push_back(i);
  }
  std::vector<int> parent(n);
  resetSets(parent);
  mergeBestPairs(m, std::move(cand), t, parent);
  for (int i = 1; i < n; ++i) parent[i] = findRoot(parent, i);
  for (int v = 0; v < labels.rows; ++v) {
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] > 0) l[u] = parent[l[u]];
  }
}

}  // namespace shapesense::segmentation
