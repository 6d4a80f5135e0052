// Step 5 of HoughPlaneDetector::detect (see hough_detector_steps.h): leftovers.
//
// Thin or small surfaces (a table's front edge, a box top seen at a grazing angle, leg faces)
// are narrower than the normal windows plus their margin at depth steps, so they have (almost)
// no reliable normals and never vote. After growing the found planes over their edges, each
// depth-continuous component of still unassigned samples is fitted by least squares; a
// component that is mostly one plane (trimmed refit) becomes a plane, any other is split by
// sequential RANSAC. A component that one plane fits but two fit far better is two faces (a table
// leg's, at a range where both lie within the tolerance of one plane through their crease).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "planes/hough_detector_steps.h"
#include "shapesense/core/geometry/moment_sums.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {
namespace {

// Per-sample buffers of countInlierNormalsAgreeing, sized to the grid once per frame: whether
// a sample is an inlier of the plane being tested (all 0 between calls), and its coordinates in
// that plane's own axes.
struct AgreementScratch {
  std::vector<std::uint8_t> member;
  std::vector<Eigen::Vector3f> local;
};

// How many of the inliers have a normal of their own, and how many of those agree with the
// plane normal n within the angle of tan_agree. An inlier's normal is the slope of the
// least-squares height field h(a, b) over the plane's axes, fitted to the inliers within kHalf
// samples of it. The sample grid's normals are useless here: their windows reach across the
// creases that bound a thin face, so every sample of a strip a few samples wide is blurred
// towards its neighbours. Normals from the inliers alone follow the surface the inliers lie on:
// a true face agrees with its plane, while a band cut from a curved surface, or a plane through
// the corner of a small box (a few samples of each face within the tolerance), keeps its
// members' own orientations.
void countInlierNormalsAgreeing(const std::vector<int>& inliers, const PlaneSampleGrid& grid,
                                const Eigen::Vector3d& n, double tan_agree,
                                AgreementScratch& scratch, int& with_normal, int& agreeing) {
  constexpr int kHalf = 2;  // a 5 x 5 sample window
  constexpr int kMinNeighbours = 6;
  const int R = grid.points.rows, C = grid.points.cols;
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
  std::vector<std::uint8_t>& member = scratch.member;
  std::vector<Eigen::Vector3f>& local = scratch.local;
  member.resize(static_cast<std::size_t>(R) * C, 0);  // no-ops after the frame's first call
  local.resize(member.size());
  // Plane coordinates relative to the first inlier, so that the sums stay well conditioned.
  const cv::Vec3f& origin = pts[inliers.front()];
  for (int i : inliers) {
    member[i] = 1;
    const Eigen::Vector3d p(pts[i][0] - origin[0], pts[i][1] - origin[1], pts[i][2] - origin[2]);
    local[i] = Eigen::Vector3d(p.dot(e1), p.dot(e2), p.dot(n)).cast<float>();
  }
  const double tan2 = tan_agree * tan_agree;
  with_normal = agreeing = 0;
  for (int i : inliers) {
    const int r = i / C, c = i % C;
    MomentSums window(Eigen::Vector3d::Zero());  // offsets in the plane's own coordinates
    for (int rr = std::max(0, r - kHalf); rr <= std::min(R - 1, r + kHalf); ++rr)
      for (int cc = std::max(0, c - kHalf); cc <= std::min(C - 1, c + kHalf); ++cc) {
        const int j = rr * C + cc;
        if (member[j]) window.addOffset(local[j].x(), local[j].y(), local[j].z());
      }
    if (window.count() < kMinNeighbours) continue;
    const std::optional<Eigen::Vector2d> slopes = window.heightSlopes();
    if (!slopes) continue;
    ++with_normal;
    agreeing += slopes->squaredNorm() <= tan2;
  }
  for (int i : inliers) member[i] = 0;
}

// Sequential RANSAC on a leftover component that is not one plane: the two visible faces of a
// small box or a table leg (joined at their convex edge), or a face joined to a curved surface
// by depth continuity. Extracts planes while the best hypothesis has enough inliers; a plane is
// kept only if its inliers mostly agree with it, each by the tilt of the inliers around it (a
// band of a bowl lies within the tolerance of some plane but its normals fan out; see
// countInlierNormalsAgreeing). Deterministic (fixed LCG).
void splitLeftoverComponent(std::vector<int> rest, const PlaneSampleGrid& grid,
                            const HoughPlaneParams& P, AgreementScratch& scratch,
                            std::vector<PlaneHypothesis>& planes, cv::Mat& sample_labels) {
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  int* lab = sample_labels.ptr<int>(0);
  const PlaneTolerance& tol = P.labeling.tolerance;
  const double tan_agree = std::tan(degToRad(P.leftover_normal_agreement_deg));
  std::uint32_t rng = 0x9E3779B9u ^ static_cast<std::uint32_t>(rest.size());
  auto next = [&rng](std::size_t n) {
    rng = rng * 1664525u + 1013904223u;
    return static_cast<std::size_t>((rng >> 8) % n);
  };
  auto dist = [&](const Eigen::Vector3d& n, double d, int i) {
    return std::fabs(n.x() * pts[i][0] + n.y() * pts[i][1] + n.z() * pts[i][2] + d);
  };
  // The tolerance of each member, aligned with `rest` (every hypothesis tests the same members).
  std::vector<double> rest_tol(rest.size()), outlier_tol;
  for (std::size_t k = 0; k < rest.size(); ++k) rest_tol[k] = tol.at(pts[rest[k]][2]);
  std::vector<int> inliers, outliers;
  std::vector<double> sub_x, sub_y, sub_z, sub_tol;
  for (int extracted = 0; extracted < 4 && static_cast<int>(rest.size()) >= P.min_plane_samples;
       ++extracted) {
    Eigen::Vector3d best_n = Eigen::Vector3d::Zero();
    double best_d = 0.0;
    std::size_t best_count = 0;
    const std::size_t stride = std::max<std::size_t>(1, rest.size() / 128);
    // The scoring subset, contiguous (every hypothesis tests the same members).
    sub_x.clear(), sub_y.clear(), sub_z.clear(), sub_tol.clear();
    for (std::size_t k = 0; k < rest.size(); k += stride) {
      const cv::Vec3f& p = pts[rest[k]];
      sub_x.push_back(p[0]), sub_y.push_back(p[1]), sub_z.push_back(p[2]);
      sub_tol.push_back(rest_tol[k]);
    }
    const std::size_t sub_n = sub_x.size();
    const double *sx = sub_x.data(), *sy = sub_y.data(), *sz = sub_z.data(), *st = sub_tol.data();
    for (int h = 0; h < P.leftover_ransac_hypotheses; ++h) {
      const auto& a = pts[rest[next(rest.size())]];
      const auto& b = pts[rest[next(rest.size())]];
      const auto& c = pts[rest[next(rest.size())]];
      const Eigen::Vector3d pa(a[0], a[1], a[2]), pb(b[0], b[1], b[2]), pc(c[0], c[1], c[2]);
      Eigen::Vector3d n = (pb - pa).cross(pc - pa);
      if (!(n.norm() > 1e-9)) continue;
      n.normalize();
      double d = -n.dot(pa);
      if (d < 0) {
        n = -n;
        d = -d;
      }
      // Scored on an even subset of at most ~128 members (the refit below uses all of them).
      const std::size_t count =
          planes_kernels::countWithin(n.x(), n.y(), n.z(), d, sx, sy, sz, st, sub_n);
      if (count > best_count) {
        best_count = count;
        best_n = n;
        best_d = d;
      }
    }
    if (static_cast<int>(best_count * stride) < P.min_plane_samples) return;
    // Least-squares refit on the inliers, twice.
    for (int it = 0; it < 2; ++it) {
      PlaneMoments mom;
      for (std::size_t k = 0; k < rest.size(); ++k) {
        const int i = rest[k];
        if (dist(best_n, best_d, i) <= rest_tol[k]) mom.add(pts[i][0], pts[i][1], pts[i][2]);
      }
      const PlaneFit fit = mom.fit();
      if (!fit.valid) return;
      best_n = fit.normal;
      best_d = fit.d;
    }
    inliers.clear();
    outliers.clear();
    outlier_tol.clear();
    for (std::size_t k = 0; k < rest.size(); ++k) {
      const int i = rest[k];
      if (dist(best_n, best_d, i) > rest_tol[k]) {
        outliers.push_back(i);
        outlier_tol.push_back(rest_tol[k]);
      } else {
        inliers.push_back(i);
      }
    }
    if (static_cast<int>(inliers.size()) < P.min_plane_samples) return;
    int with_normal = 0, agreeing = 0;
    countInlierNormalsAgreeing(inliers, grid, best_n, tan_agree, scratch, with_normal, agreeing);
    if (with_normal >= 6 && agreeing < P.leftover_min_inlier_fraction * with_normal) return;
    const int id = static_cast<int>(planes.size());
    for (int i : inliers) lab[i] = id;
    planes.push_back({best_n, best_d});
    rest.swap(outliers);
    rest_tol.swap(outlier_tol);
  }
}

// The depth-continuous component of unassigned valid samples around `seed` (4-connected), into
// members; comp marks the samples taken (with the seed).
void floodComponent(int seed, const PlaneSampleGrid& grid, const int* lab,
                    const SampleContinuity& continuous, std::vector<int>& comp,
                    std::vector<int>& stack, std::vector<int>& members) {
  const int R = grid.points.rows, C = grid.points.cols;
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  members.clear();
  stack.assign(1, seed);
  comp[seed] = seed;
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    members.push_back(i);
    const int r = i / C, c = i % C;
    const int nbr[4] = {c > 0 ? i - 1 : -1, c + 1 < C ? i + 1 : -1, r > 0 ? i - C : -1,
                        r + 1 < R ? i + C : -1};
    for (int j : nbr) {
      if (j < 0 || comp[j] >= 0 || lab[j] >= 0 || !(pts[j][2] > 0)) continue;
      if (!continuous(pts[i][2], pts[j][2])) continue;
      comp[j] = seed;
      stack.push_back(j);
    }
  }
}

// Distance of sample point p from the plane of `fit`.
double planeDistance(const PlaneFit& fit, const cv::Vec3f& p) {
  return std::fabs(fit.normal.x() * p[0] + fit.normal.y() * p[1] + fit.normal.z() * p[2] + fit.d);
}

// The least-squares plane of a component, trimmed three times (within 3x the tolerance, then
// twice within the tolerance); inliers: how many the last trim kept.
PlaneFit trimmedComponentFit(const std::vector<int>& members, const std::vector<double>& member_tol,
                             const cv::Vec3f* pts, std::size_t& inliers) {
  PlaneMoments mom;
  for (int i : members) mom.add(pts[i][0], pts[i][1], pts[i][2]);
  PlaneFit fit = mom.fit();
  inliers = 0;
  for (int it = 0; it < 3 && fit.valid; ++it) {
    const double mult = it == 0 ? 3.0 : 1.0;
    PlaneMoments trimmed;
    inliers = 0;
    for (std::size_t k = 0; k < members.size(); ++k) {
      const int i = members[k];
      if (planeDistance(fit, pts[i]) > mult * member_tol[k]) continue;
      trimmed.add(pts[i][0], pts[i][1], pts[i][2]);
      ++inliers;
    }
    fit = trimmed.fit();
  }
  return fit;
}

// A component becomes a plane when one plane fits most of it, or two when it is two faces;
// otherwise it is split by RANSAC.
void fitComponent(const std::vector<int>& members, const PlaneSampleGrid& grid,
                  const HoughPlaneParams& P, std::vector<double>& member_tol,
                  AgreementScratch& scratch, std::vector<PlaneHypothesis>& planes,
                  cv::Mat& sample_labels) {
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  member_tol.resize(members.size());  // tested by every trimming pass
  for (std::size_t k = 0; k < members.size(); ++k)
    member_tol[k] = P.labeling.tolerance.at(pts[members[k]][2]);
  std::size_t inliers = 0;
  const PlaneFit fit = trimmedComponentFit(members, member_tol, pts, inliers);
  if (!fit.valid || static_cast<int>(inliers) < P.min_plane_samples ||
      static_cast<double>(inliers) <
          P.leftover_min_inlier_fraction * static_cast<double>(members.size())) {
    if (P.leftover_ransac_hypotheses > 0)
      splitLeftoverComponent(members, grid, P, scratch, planes, sample_labels);
    return;
  }
  if (mayBeTwoFaces(members.size(), P)) {
    std::vector<Eigen::Vector3d> points;
    gatherSamplePoints(grid, members, points);
    if (const std::optional<TwoPlanes> faces = twoFaces(points, fit, P)) {
      const int a = static_cast<int>(planes.size());
      labelNearerFace(*faces, members, points, a, a + 1, &member_tol, sample_labels);
      planes.push_back({faces->a.normal, faces->a.d});
      planes.push_back({faces->b.normal, faces->b.d});
      return;
    }
  }
  const int id = static_cast<int>(planes.size());
  int* lab = sample_labels.ptr<int>(0);
  for (std::size_t k = 0; k < members.size(); ++k) {
    const int i = members[k];
    if (planeDistance(fit, pts[i]) <= member_tol[k]) lab[i] = id;
  }
  planes.push_back({fit.normal, fit.d});
}

}  // namespace

void HoughPlaneDetector::Impl::fitLeftoverComponents(const HoughPlaneParams& P,
                                                     std::vector<PlaneHypothesis>& planes) {
  growSampleLabels(grid, sample_labels, planes, P.labeling);
  const SampleContinuity continuous(grid, P.labeling);
  const int N = grid.points.rows * grid.points.cols;
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const int* lab = sample_labels.ptr<int>(0);
  comp.assign(N, -1);
  std::vector<int> stack, members;
  std::vector<double> member_tol;
  AgreementScratch scratch;
  // The possible seeds (unassigned, valid) first, in a branch-free pass: a sample labelled
  // by an earlier component below was one of its members, which the comp test skips.
  seeds.resize(N);
  int seed_count = 0;
  for (int i = 0; i < N; ++i) {
    seeds[seed_count] = i;
    seed_count += (lab[i] < 0) & (pts[i][2] > 0);
  }
  for (int q = 0; q < seed_count; ++q) {
    const int seed = seeds[q];
    if (comp[seed] >= 0) continue;
    floodComponent(seed, grid, lab, continuous, comp, stack, members);
    if (static_cast<int>(members.size()) < P.min_plane_samples) continue;
    fitComponent(members, grid, P, member_tol, scratch, planes, sample_labels);
  }
}

}  // namespace shapesense
