// Steps 1-3 of HoughPlaneDetector::detect (see hough_detector_steps.h): sampling, reliable
// samples, and the voting rounds with the refinement of each peak into a plane.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>

#include "planes/hough_detector_steps.h"
#include "shapesense/core/geometry/moment_sums.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {
namespace {

using planes_kernels::PlaneGates;
using planes_kernels::SampleArrays;

// The gates of the plane n . X + d = 0, in the floats the kernels compare.
PlaneGates planeGates(const Eigen::Vector3d& n, double d, float gate_mult, float cos_normal) {
  return {static_cast<float>(n.x()),
          static_cast<float>(n.y()),
          static_cast<float>(n.z()),
          static_cast<float>(d),
          gate_mult,
          cos_normal};
}

// PlaneMoments(ref) after add(x[k], y[k], z[k]) for the k in 0 .. count-1 with in[k] (in ==
// nullptr: all), the same moments. (Skipping a point gives the sums adding zeros for it would:
// a sum that starts at +0 is never -0, round to nearest giving -0 only for -0 + -0, and adding
// +0 leaves any other value unchanged.) Nearly all candidates are in (the branch is
// predictable).
PlaneMoments candidateMoments(const Eigen::Vector3d& ref, const float* x, const float* y,
                              const float* z, const std::uint8_t* in, int count) {
  MomentSums sums(ref);
  for (int k = 0; k < count; ++k)
    if (in == nullptr || in[k] != 0) sums.add(x[k], y[k], z[k]);
  return sums.moments();
}

}  // namespace

bool HoughPlaneDetector::Impl::sampleFrame(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                           const HoughPlaneParams& P) {
  grid.build(depth_mm, K, P.labeling.sample_step);
  if (grid.points.empty()) {
    sample_labels.create(grid.points.size(), CV_32SC1);
    return false;
  }
  normals_est.compute(grid.depth_mm, grid.intrinsics, grid.normals);
  return true;
}

void HoughPlaneDetector::Impl::markReliableSamples(const HoughPlaneParams& P) {
  const int R = grid.points.rows, C = grid.points.cols, N = R * C;
  const float cos_spread = static_cast<float>(std::cos(degToRad(P.vote_max_normal_spread_deg)));
  grid.reliable.create(R, C, CV_8UC1);
  grid.reliable.setTo(0);
  auto* reliable = grid.reliable.ptr<std::uint8_t>(0);
  // Branch-free (the four tests fail unpredictably along edges and holes). A NaN normal, own or
  // a neighbour's, makes its dot product NaN, which fails the comparison.
  // Each neighbour pair is tested once (the dot product is symmetric, bit for bit): across[i]
  // = whether sample i agrees with i + 1 (interior rows, the only ones read below; one run
  // from the second row's first sample, so the last sample of a row is compared with the next
  // row's first too, never read), down[i] = whether it agrees with i + C (every row but the
  // last).
  agree_across.resize(N);
  agree_down.resize(N);
  std::uint8_t* across = agree_across.data();
  std::uint8_t* down = agree_down.data();
  const float* normals = grid.normals.ptr<float>(0);
  if (R > 2) planes_kernels::normalAgreement(normals, 1, cos_spread, C, (R - 1) * C - 1, across);
  planes_kernels::normalAgreement(normals, C, cos_spread, 0, N - C, down);
  for (int r = 1; r + 1 < R; ++r)
    for (int c = 1; c + 1 < C; ++c) {
      const int i = r * C + c;
      reliable[i] = across[i - 1] & across[i] & down[i - C] & down[i];
    }
}

HoughPlaneDetector::Impl::RoundGates HoughPlaneDetector::Impl::roundGates(
    const HoughPlaneParams& P) const {
  RoundGates g;
  g.cos_inlier = static_cast<float>(std::cos(degToRad(P.inlier_max_normal_deg)));
  const double peak_per_vote = raw.kernelPeak(P.sigma_angle_deg, P.sigma_d_m);
  g.min_peak = static_cast<float>(0.5 * P.min_plane_samples * peak_per_vote);
  g.min_block_mass = std::max(2.0f, P.min_plane_samples / 6.0f);
  // Widest gate first: the peak's d is only as good as the kernel (a parallel plane nearby
  // shifts it), so start at the kernel's spread and shrink to the sensor tolerance.
  g.wide = static_cast<float>(2.5 * P.sigma_d_m);
  return g;
}

void HoughPlaneDetector::Impl::prepareRounds(const HoughPlaneParams& P) {
  const int N = grid.points.rows * grid.points.cols;
  sample_labels.create(grid.points.rows, grid.points.cols, CV_32SC1);
  sample_labels.setTo(-1);
  for (auto* v : {&fx, &fy, &fz, &fnx, &fny, &fnz, &ftol, &fgate, &vx, &vy, &vz, &vd}) v->resize(N);
  free_idx.resize(N);
  fin.resize(N);
  // Each sample's inlier tolerance, once per frame (tol.at costs a division; the rounds would
  // recompute it for every free sample).
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const auto* nrm = grid.normals.ptr<cv::Vec3f>(0);
  sample_tol.resize(N);
  for (int i = 0; i < N; ++i)
    if (nrm[i][2] == nrm[i][2])
      sample_tol[i] = static_cast<float>(P.labeling.tolerance.at(pts[i][2]));
}

int HoughPlaneDetector::Impl::collectFreeSamples(float wide, int& votes) {
  const int N = grid.points.rows * grid.points.cols;
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const auto* nrm = grid.normals.ptr<cv::Vec3f>(0);
  const auto* reliable = grid.reliable.ptr<std::uint8_t>(0);
  const int* lab = sample_labels.ptr<int>(0);
  int F = 0;
  votes = 0;
  for (int i = 0; i < N; ++i) {
    if (lab[i] >= 0) continue;
    const cv::Vec3f& n = nrm[i];
    if (!(n[2] == n[2])) continue;
    const cv::Vec3f& p = pts[i];
    free_idx[F] = i;
    fx[F] = p[0], fy[F] = p[1], fz[F] = p[2];
    fnx[F] = n[0], fny[F] = n[1], fnz[F] = n[2];
    ftol[F] = sample_tol[i];
    fgate[F] = std::max(wide, 2.0f * ftol[F]);
    ++F;
    if (!reliable[i]) continue;
    vx[votes] = n[0], vy[votes] = n[1], vz[votes] = n[2];
    vd[votes] = -(n[0] * p[0] + n[1] * p[1] + n[2] * p[2]);
    ++votes;
  }
  return F;
}

SampleArrays HoughPlaneDetector::Impl::freeSamples() const {
  // The gate of the candidate scan is fgate itself (the scan multiplies it by 1: exact).
  return {fx.data(), fy.data(), fz.data(), fnx.data(), fny.data(), fnz.data(), fgate.data()};
}

SampleArrays HoughPlaneDetector::Impl::candidateSamples() const {
  return {cx.data(), cy.data(), cz.data(), cnx.data(), cny.data(), cnz.data(), ctol.data()};
}

int HoughPlaneDetector::Impl::scanCandidates(const PlaneGates& gates, int free_count) {
  // Two branch-free loops (most samples fail, unpredictably): the tests (a kernel), then the
  // compaction, where every index is written and only the kept ones advance the end.
  std::uint8_t* in = fin.data();
  planes_kernels::gateFlags(gates, freeSamples(), nullptr, in, free_count);
  if (cand.size() < static_cast<std::size_t>(free_count)) cand.resize(fin.size());
  int kept = 0, f = 0;
  // Most samples fail for most maxima, in long stretches: skip 8 flags at a time.
  for (; f + 8 <= free_count; f += 8) {
    std::uint64_t any;
    std::memcpy(&any, in + f, sizeof any);
    if (!any) continue;
    for (int t = f; t < f + 8; ++t) {
      cand[kept] = t;
      kept += in[t];
    }
  }
  for (; f < free_count; ++f) {
    cand[kept] = f;
    kept += in[f];
  }
  return kept;
}

void HoughPlaneDetector::Impl::gatherCandidates(int num_cand) {
  for (auto* v : {&cx, &cy, &cz, &cnx, &cny, &cnz, &ctol}) v->resize(num_cand);
  calive.assign(num_cand, 1);
  cin.resize(num_cand);
  for (int k = 0; k < num_cand; ++k) {
    const int f = cand[k];
    cx[k] = fx[f], cy[k] = fy[f], cz[k] = fz[f];
    cnx[k] = fnx[f], cny[k] = fny[f], cnz[k] = fnz[f];
    ctol[k] = ftol[f];
  }
}

bool HoughPlaneDetector::Impl::refineCandidates(const HoughPlaneParams& P, float cos_inlier,
                                                int num_cand, Eigen::Vector3d& n, double& d) {
  // `alive` marks the current set, and candidateMoments skips the candidates that left it.
  const SampleArrays candidates = candidateSamples();
  std::uint8_t* alive = calive.data();
  std::uint8_t* next_set = cin.data();
  int first = 0;  // the first candidate of the current set
  const int iters = std::max(1, P.refine_iterations);
  for (int it = 0; it < iters; ++it) {
    // Gate schedule: wide (the candidate scan's gate), 2x tolerance, then the tolerance.
    // The normal gate stays tight throughout: the smoothed peak's normal is already good to
    // a degree or two, and a wide gate would let two crossing surfaces of similar d (a box
    // face and the table edge behind it) pull the fit to a plane between them.
    // Relative to a point of the candidate set (precision at metres of range).
    const Eigen::Vector3d ref(cx[first], cy[first], cz[first]);
    PlaneMoments mom;
    if (it == 0) {
      // The first pass's gates are the candidate scan's, with the same plane: every
      // candidate passes, and the wide set stays for the first shrink.
      mom = candidateMoments(ref, cx.data(), cy.data(), cz.data(), nullptr, num_cand);
    } else {
      const PlaneGates gates = planeGates(n, d, it == 1 ? 2.0f : 1.0f, cos_inlier);
      planes_kernels::gateFlags(gates, candidates, alive, next_set, num_cand);
      int kept = 0;
      for (int k = 0; k < num_cand; ++k) kept += next_set[k];
      if (kept == 0 || kept < P.min_plane_samples) return false;
      mom = candidateMoments(ref, cx.data(), cy.data(), cz.data(), next_set, num_cand);
      std::swap(alive, next_set);
      while (!alive[first]) ++first;
    }
    const PlaneFit fit = mom.fit();
    if (!fit.valid) return false;
    n = fit.normal;
    d = fit.d;
  }
  alive_ = alive;
  spare_ = next_set;
  return true;
}

int HoughPlaneDetector::Impl::finalInliers(const Eigen::Vector3d& n, double d, float cos_inlier,
                                           int num_cand) {
  // Final inliers at the tolerance with the refined plane, then compacted as the candidates
  // were. (A candidate still alive passed these tests with an earlier plane: its point and
  // normal are not NaN. The plane is finite too, since fit() returns a finite normal and d for
  // finite points (the eigenvectors of a finite covariance), so no comparison sees a NaN and
  // "not rejected" is "accepted".)
  planes_kernels::gateFlags(planeGates(n, d, 1.0f, cos_inlier), candidateSamples(), alive_, spare_,
                            num_cand);
  next.resize(num_cand);
  int inliers = 0;
  for (int k = 0; k < num_cand; ++k) {
    next[inliers] = cand[k];
    inliers += spare_[k];
  }
  next.resize(inliers);
  return inliers;
}

bool HoughPlaneDetector::Impl::acceptMaximum(const HoughPlaneParams& P, const RoundGates& g,
                                             const HoughMaximum& m, int free_count,
                                             std::vector<PlaneHypothesis>& planes) {
  Eigen::Vector3d n = m.normal;
  double d = m.d;
  const int num_cand = scanCandidates(planeGates(n, d, 1.0f, g.cos_inlier), free_count);
  if (num_cand == 0 || num_cand < P.min_plane_samples) return false;
  gatherCandidates(num_cand);
  if (!refineCandidates(P, g.cos_inlier, num_cand, n, d)) return false;
  if (finalInliers(n, d, g.cos_inlier, num_cand) < P.min_plane_samples) return false;
  const int id = static_cast<int>(planes.size());
  int* lab = sample_labels.ptr<int>(0);
  for (const int f : next) {
    lab[free_idx[f]] = id;
    fgate[f] = -1.0f;
  }
  planes.push_back({n, d});
  return true;
}

std::vector<PlaneHypothesis> HoughPlaneDetector::Impl::findPlanesByVoting(
    const HoughPlaneParams& P) {
  prepareRounds(P);
  const RoundGates g = roundGates(P);
  std::vector<PlaneHypothesis> planes;
  for (int round = 0; round < std::max(1, P.rounds); ++round) {
    // Vote with the free reliable samples; refine the maxima, strongest first; accepted planes
    // claim their samples, which no longer vote in the next round.
    raw.clear();
    int votes = 0;
    const int free_count = collectFreeSamples(g.wide, votes);
    raw.voteBatch(vx.data(), vy.data(), vz.data(), vd.data(), votes);
    if (votes < P.min_plane_samples) break;
    raw.smoothInto(smooth, P.sigma_angle_deg, P.sigma_d_m, g.min_block_mass, g.min_peak);
    const auto maxima = smooth.findMaxima(g.min_peak, P.maxima_window_a, P.maxima_window_d);
    const int tried = std::min<int>(static_cast<int>(maxima.size()), P.max_candidates_per_round);
    int accepted = 0;
    for (int m = 0; m < tried; ++m) accepted += acceptMaximum(P, g, maxima[m], free_count, planes);
    if (accepted == 0) break;
  }
  return planes;
}

}  // namespace shapesense
