// Step 4 of HoughPlaneDetector::detect: merging near-duplicate planes (see
// hough_detector_steps.h).
//
// The same plane found from two maxima or in two rounds, or (after the leftover step) a thin
// strip found in pieces whose separate fits disagree by a few degrees because a strip constrains
// its normal poorly across its width. Two planes within merge_angle_deg merge when the
// least-squares fit of their union is nearly as good as theirs: RMS <= max(merge_rms_factor x
// the worse of the two, merge_tolerance_factor x the inlier tolerance at the farther plane's
// mean range / 3). A box top 5 cm above the table fails by far (the union's RMS is ~2.5 cm).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "planes/hough_detector_steps.h"
#include "shapesense/core/geometry/moment_sums.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {
namespace {

// The moments of each plane's labelled samples (the first sample is the reference) and the sum
// of their ranges.
struct LabelledMoments {
  std::vector<PlaneMoments> moments;
  std::vector<double> z_sum;
};

LabelledMoments labelledMoments(const PlaneSampleGrid& grid, const int* lab, std::size_t planes) {
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const int N = grid.points.rows * grid.points.cols;
  LabelledMoments out;
  out.z_sum.assign(planes, 0.0);
  // Runs of samples share a plane: its moments stay in locals until the plane changes (the
  // same additions in the same order, without a round trip through memory per sample).
  std::vector<MomentSums> sums(planes);
  int cur = -1;
  MomentSums cur_sums;
  double cur_z = 0.0;
  for (int i = 0; i < N; ++i) {
    const int L = lab[i];
    if (L < 0) continue;
    if (L != cur) {
      if (cur >= 0) {
        sums[cur] = cur_sums;
        out.z_sum[cur] = cur_z;
      }
      cur = L;
      cur_sums = sums[L];
      cur_z = out.z_sum[L];
      if (!cur_sums.hasReference())
        cur_sums.setReference(Eigen::Vector3d(pts[i][0], pts[i][1], pts[i][2]));
    }
    cur_sums.add(pts[i]);
    cur_z += pts[i][2];
  }
  if (cur >= 0) {
    sums[cur] = cur_sums;
    out.z_sum[cur] = cur_z;
  }
  out.moments.resize(planes);
  for (std::size_t p = 0; p < planes; ++p) out.moments[p] = sums[p].moments();
  return out;
}

// The planes being merged: their moments, fits and pair scores (joint RMS / limit; infinity =
// no merge), kept between merges: a merge changes only the pairs of its two planes, and each
// score costs an eigen-solve.
class MergeTable {
 public:
  MergeTable(LabelledMoments m, const HoughPlaneParams& P)
      : P_(P),
        cos_merge_(std::cos(degToRad(P.merge_angle_deg))),
        count_(m.moments.size()),
        mom_(std::move(m.moments)),
        z_sum_(std::move(m.z_sum)),
        fits_(count_),
        score_(count_ * count_, kUnknown) {
    for (std::size_t i = 0; i < count_; ++i) fits_[i] = mom_[i].fit();
  }

  // The pair with the lowest score, i < j; false when no pair may merge.
  bool bestPair(int& bi, int& bj) {
    double best = 1e30;
    bi = bj = -1;
    for (std::size_t i = 0; i < count_; ++i) {
      if (!fits_[i].valid) continue;
      for (std::size_t j = i + 1; j < count_; ++j) {
        const double sc = pairScore(i, j);
        if (sc < best) {
          best = sc;
          bi = static_cast<int>(i);
          bj = static_cast<int>(j);
        }
      }
    }
    return bi >= 0;
  }

  // Merges plane j into plane i; the fit of the union.
  const PlaneFit& merge(int i, int j) {
    mom_[i].merge(mom_[j]);
    mom_[j] = PlaneMoments();
    z_sum_[i] += z_sum_[j];
    z_sum_[j] = 0.0;
    fits_[i] = mom_[i].fit();
    fits_[j] = PlaneFit();
    for (std::size_t k = 0; k < count_; ++k)
      for (const int m : {i, j}) score_[k * count_ + m] = score_[m * count_ + k] = kUnknown;
    return fits_[i];
  }

 private:
  static constexpr double kUnknown = -1.0;

  double pairScore(std::size_t i, std::size_t j) {
    double& sc = score_[i * count_ + j];
    if (sc != kUnknown) return sc;
    sc = std::numeric_limits<double>::infinity();
    if (!fits_[i].valid || !fits_[j].valid || fits_[i].normal.dot(fits_[j].normal) < cos_merge_)
      return sc;
    PlaneMoments u = mom_[i];
    u.merge(mom_[j]);
    const PlaneFit f = u.fit();
    const double z = std::max(z_sum_[i] / mom_[i].count(), z_sum_[j] / mom_[j].count());
    const double limit = std::max(P_.merge_rms_factor * std::max(fits_[i].rms_m, fits_[j].rms_m),
                                  P_.merge_tolerance_factor * P_.labeling.tolerance.at(z) / 3.0);
    if (f.valid && f.rms_m <= limit) sc = f.rms_m / limit;
    return sc;
  }

  const HoughPlaneParams& P_;
  double cos_merge_;
  std::size_t count_;
  std::vector<PlaneMoments> mom_;
  std::vector<double> z_sum_;
  std::vector<PlaneFit> fits_;
  std::vector<double> score_;
};

}  // namespace

void mergeNearDuplicatePlanes(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                              std::vector<PlaneHypothesis>& planes, const HoughPlaneParams& P) {
  int* lab = sample_labels.ptr<int>(0);
  // Moments once; a merge then adds the pair's moments and relabels at the end.
  MergeTable table(labelledMoments(grid, lab, planes.size()), P);
  std::vector<int> merged_into(planes.size());
  std::iota(merged_into.begin(), merged_into.end(), 0);
  bool merged_any = false;
  for (int bi, bj; table.bestPair(bi, bj);) {
    const PlaneFit& fit = table.merge(bi, bj);
    merged_into[bj] = bi;
    merged_any = true;
    planes[bi] = {fit.normal, fit.d};
    planes[bj] = {Eigen::Vector3d(0, 0, -1), -1.0};  // unused from now on (no samples)
  }
  if (!merged_any) return;
  std::vector<int> survivor(planes.size());
  for (std::size_t j = 0; j < planes.size(); ++j) {
    int k = static_cast<int>(j);
    while (merged_into[k] != k) k = merged_into[k];
    survivor[j] = k;
  }
  const int N = grid.points.rows * grid.points.cols;
  for (int i = 0; i < N; ++i)
    if (lab[i] >= 0) lab[i] = survivor[lab[i]];
}

}  // namespace shapesense
