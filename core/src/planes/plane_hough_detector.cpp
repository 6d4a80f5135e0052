#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <vector>

#include <Eigen/Geometry>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "cpu_dispatch.h"  // SHAPESENSE_AVX2_PATHS: the AVX2 variants below (GCC only)
#include "shapesense/core/planes/plane_labeling.h"
#include "shapesense/core/planes/planes.h"

namespace shapesense {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

#if defined(SHAPESENSE_AVX2_PATHS)
// countWithin (below), four points per AVX2 register: lane for lane the same operations
// (nothing fused into FMA: the build has -ffp-contract=off).
[[gnu::target("avx2")]] std::size_t countWithinAvx2(double nx, double ny, double nz, double d,
                                                    const double* x, const double* y,
                                                    const double* z, const double* tol,
                                                    std::size_t n) {
  const __m256d vnx = _mm256_set1_pd(nx), vny = _mm256_set1_pd(ny), vnz = _mm256_set1_pd(nz),
                vd = _mm256_set1_pd(d), sign = _mm256_set1_pd(-0.0);
  __m256i counts = _mm256_setzero_si256();  // minus the number of inliers, per lane
  std::size_t k = 0;
  for (; k + 4 <= n; k += 4) {
    const __m256d dot =
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vnx, _mm256_loadu_pd(x + k)),
                                                  _mm256_mul_pd(vny, _mm256_loadu_pd(y + k))),
                                    _mm256_mul_pd(vnz, _mm256_loadu_pd(z + k))),
                      vd);
    const __m256d within =
        _mm256_cmp_pd(_mm256_andnot_pd(sign, dot), _mm256_loadu_pd(tol + k), _CMP_LE_OQ);
    counts = _mm256_add_epi64(counts, _mm256_castpd_si256(within));  // a true lane is -1
  }
  alignas(32) std::int64_t lanes[4];
  _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), counts);
  std::size_t count = static_cast<std::size_t>(-(lanes[0] + lanes[1] + lanes[2] + lanes[3]));
  for (; k < n; ++k) count += std::fabs(nx * x[k] + ny * y[k] + nz * z[k] + d) <= tol[k];
  return count;
}
#endif

// How many of the n points (x, y, z) lie within tol of plane (normal, d): |normal.p + d| <=
// tol, evaluated left to right in double. Two points per SSE2 register, or four with AVX2
// (the same operations, lane for lane; GCC does not vectorise the counting loop itself).
std::size_t countWithin(const Eigen::Vector3d& normal, double d, const double* x, const double* y,
                        const double* z, const double* tol, std::size_t n) {
  const double nx = normal.x(), ny = normal.y(), nz = normal.z();
#if defined(SHAPESENSE_AVX2_PATHS)
  if (detail::cpuHasAvx2()) return countWithinAvx2(nx, ny, nz, d, x, y, z, tol, n);
#endif
  std::size_t count = 0, k = 0;
#if defined(__SSE2__)
  const __m128d vnx = _mm_set1_pd(nx), vny = _mm_set1_pd(ny), vnz = _mm_set1_pd(nz),
                vd = _mm_set1_pd(d), sign = _mm_set1_pd(-0.0);
  __m128i counts = _mm_setzero_si128();  // minus the number of inliers, per lane
  for (; k + 2 <= n; k += 2) {
    const __m128d dot = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(vnx, _mm_loadu_pd(x + k)),
                                                         _mm_mul_pd(vny, _mm_loadu_pd(y + k))),
                                              _mm_mul_pd(vnz, _mm_loadu_pd(z + k))),
                                   vd);
    const __m128d within = _mm_cmple_pd(_mm_andnot_pd(sign, dot), _mm_loadu_pd(tol + k));
    counts = _mm_add_epi64(counts, _mm_castpd_si128(within));  // a true lane is -1
  }
  alignas(16) std::int64_t lanes[2];
  _mm_store_si128(reinterpret_cast<__m128i*>(lanes), counts);
  count = static_cast<std::size_t>(-(lanes[0] + lanes[1]));
#endif
  for (; k < n; ++k) count += std::fabs(nx * x[k] + ny * y[k] + nz * z[k] + d) <= tol[k];
  return count;
}

// Samples as structure of arrays: points, unit normals (NaN = none) and distance tolerances.
struct SampleArrays {
  const float *x, *y, *z, *nx, *ny, *nz, *tol;
};

// A plane and the gates of a refinement test, in float as the scans evaluate them.
struct PlaneGates {
  float nx, ny, nz, d;
  float gate_mult;   // distance gate: gate_mult x the sample's tolerance
  float cos_normal;  // the normals' dot product must reach this
};

// The gates of the plane n . X + d = 0, in the floats the loops compare.
PlaneGates planeGates(const Eigen::Vector3d& n, double d, float gate_mult, float cos_normal) {
  return {static_cast<float>(n.x()),
          static_cast<float>(n.y()),
          static_cast<float>(n.z()),
          static_cast<float>(d),
          gate_mult,
          cos_normal};
}

// Branch-free loops over every sample (the tests fail unpredictably) that vectorise; the
// *Avx2 variants are the same code compiled for AVX2 (nothing fused into FMA: the build has
// -ffp-contract=off; the same operations, lane for lane: the same bits) and run where the CPU
// has it (detail::cpuHasAvx2, checked once).
//
// in[k] = (alive == nullptr || alive[k]) && |plane . p_k| <= gate_mult tol[k] && the normals
// agree.
[[gnu::always_inline]] inline void gateFlagsLoop(const PlaneGates& g, const SampleArrays& a,
                                                 const std::uint8_t* alive, std::uint8_t* in,
                                                 int count) {
  // Locals: the byte stores could alias the structs' members, not these (so it vectorises).
  const float *x = a.x, *y = a.y, *z = a.z, *nx = a.nx, *ny = a.ny, *nz = a.nz, *tol = a.tol;
  const float px = g.nx, py = g.ny, pz = g.nz, pd = g.d, mult = g.gate_mult, cos_n = g.cos_normal;
  auto dist = [=](int k) { return std::fabs(px * x[k] + py * y[k] + pz * z[k] + pd); };
  auto agrees = [=](int k) { return px * nx[k] + py * ny[k] + pz * nz[k] >= cos_n; };
  if (alive == nullptr && mult == 1.0f)  // (1 x the tolerance is the tolerance: one multiply less)
    for (int k = 0; k < count; ++k)
      in[k] = static_cast<std::uint8_t>((dist(k) <= tol[k]) & agrees(k));
  else if (alive == nullptr)
    for (int k = 0; k < count; ++k)
      in[k] = static_cast<std::uint8_t>((dist(k) <= mult * tol[k]) & agrees(k));
  else
    for (int k = 0; k < count; ++k)
      in[k] = static_cast<std::uint8_t>(alive[k] & (dist(k) <= mult * tol[k]) & agrees(k));
}

// agree[i] = whether normals i and i + offset (interleaved x, y, z) are within the angle whose
// cosine is cos_max, for i in [begin, end). NaN normals never agree.
[[gnu::always_inline]] inline void normalAgreementLoop(const float* normals, int offset,
                                                       float cos_max, int begin, int end,
                                                       std::uint8_t* agree) {
  const float* m = normals + 3 * offset;
  for (int i = begin; i < end; ++i)
    agree[i] =
        static_cast<std::uint8_t>(normals[3 * i] * m[3 * i] + normals[3 * i + 1] * m[3 * i + 1] +
                                      normals[3 * i + 2] * m[3 * i + 2] >=
                                  cos_max);
}

void gateFlagsDefault(const PlaneGates& g, const SampleArrays& a, const std::uint8_t* alive,
                      std::uint8_t* in, int count) {
  gateFlagsLoop(g, a, alive, in, count);
}
void normalAgreementDefault(const float* normals, int offset, float cos_max, int begin, int end,
                            std::uint8_t* agree) {
  normalAgreementLoop(normals, offset, cos_max, begin, end, agree);
}

#if defined(SHAPESENSE_AVX2_PATHS)
[[gnu::target("avx2")]] void gateFlagsAvx2(const PlaneGates& g, const SampleArrays& a,
                                           const std::uint8_t* alive, std::uint8_t* in, int count) {
  gateFlagsLoop(g, a, alive, in, count);
}
[[gnu::target("avx2")]] void normalAgreementAvx2(const float* normals, int offset, float cos_max,
                                                 int begin, int end, std::uint8_t* agree) {
  normalAgreementLoop(normals, offset, cos_max, begin, end, agree);
}
#endif

// Out of line: inlined (three call sites in detect) it made GCC stop inlining
// PlaneMoments::add into detect.
[[gnu::noinline]] void gateFlags(const PlaneGates& g, const SampleArrays& a,
                                 const std::uint8_t* alive, std::uint8_t* in, int count) {
#if defined(SHAPESENSE_AVX2_PATHS)
  if (detail::cpuHasAvx2()) return gateFlagsAvx2(g, a, alive, in, count);
#endif
  gateFlagsDefault(g, a, alive, in, count);
}
void normalAgreement(const float* normals, int offset, float cos_max, int begin, int end,
                     std::uint8_t* agree) {
#if defined(SHAPESENSE_AVX2_PATHS)
  if (detail::cpuHasAvx2()) return normalAgreementAvx2(normals, offset, cos_max, begin, end, agree);
#endif
  normalAgreementDefault(normals, offset, cos_max, begin, end, agree);
}

// The sums of PlaneMoments (w = 1) in registers, for loops over many points: two of them per
// SSE2 register, lane for lane the additions PlaneMoments::add makes, in the same order, so
// moments() equals the PlaneMoments the same add() calls give. Needs a reference (the first
// point, as add() takes it, or the caller's).
class MomentSums {
 public:
  MomentSums() = default;
  explicit MomentSums(const Eigen::Vector3d& ref) { setReference(ref); }
  bool hasReference() const { return has_ref_; }
  void setReference(const Eigen::Vector3d& ref) {
    ref_ = ref;
    has_ref_ = true;
#if defined(__SSE2__)
    ref_xy_ = _mm_set_pd(ref.y(), ref.x());
#endif
  }
  /// Needs a reference (the constructor's or setReference's): without one the sums would be
  /// taken relative to (0, 0, 0), unlike PlaneMoments::add.
  void add(float x, float y, float z) {
    assert(has_ref_);
#if defined(__SSE2__)
    addXY(_mm_unpacklo_ps(_mm_set_ss(x), _mm_set_ss(y)), z);
#else
    addScalar(x, y, z);
#endif
  }
  /// add(p[0], p[1], p[2]), x and y in one load.
  void add(const cv::Vec3f& p) {
    assert(has_ref_);
#if defined(__SSE2__)
    double xy;  // the bytes of p[0] and p[1] (memcpy: one load, no aliasing question)
    std::memcpy(&xy, &p[0], sizeof xy);
    addXY(_mm_castpd_ps(_mm_set_sd(xy)), p[2]);
#else
    addScalar(p[0], p[1], p[2]);
#endif
  }
  /// PlaneMoments() when no reference was set.
  PlaneMoments moments() const {
    if (!has_ref_) return PlaneMoments();
#if defined(__SSE2__)
    alignas(16) double s[2], ss[6];
    _mm_store_pd(s, s_ab_);
    _mm_store_pd(ss, aa_ab_);
    _mm_store_pd(ss + 2, ac_bb_);
    _mm_store_pd(ss + 4, bc_cc_);
    const Eigen::Vector3d sum(s[0], s[1], s_c_);
    // ss: a a, a b, a c, b b, b c, c c
#else
    const Eigen::Vector3d sum(s_[0], s_[1], s_[2]);
    const double* ss = ss_;
#endif
    Eigen::Matrix3d sq;
    sq << ss[0], ss[1], ss[2], 0.0, ss[3], ss[4], 0.0, 0.0, ss[5];
    return PlaneMoments::fromSums(ref_, n_, sum, sq);
  }

 private:
#if defined(__SSE2__)
  // x and y in the two low lanes of xy.
  void addXY(__m128 xy, float z) {
    // (a, b) and c as PlaneMoments::add computes them from the doubles of x, y, z.
    const __m128d ab = _mm_sub_pd(_mm_cvtps_pd(xy), ref_xy_);
    const __m128d c = _mm_set1_pd(static_cast<double>(z) - ref_.z());
    n_ += 1.0;
    s_ab_ = _mm_add_pd(s_ab_, ab);
    s_c_ += _mm_cvtsd_f64(c);
    aa_ab_ = _mm_add_pd(aa_ab_, _mm_mul_pd(_mm_unpacklo_pd(ab, ab), ab));  // (a a, a b)
    ac_bb_ = _mm_add_pd(ac_bb_, _mm_mul_pd(ab, _mm_move_sd(ab, c)));       // (a c, b b)
    bc_cc_ = _mm_add_pd(bc_cc_, _mm_mul_pd(_mm_unpackhi_pd(ab, c), c));    // (b c, c c)
  }
#else
  void addScalar(float x, float y, float z) {
    const double a = x - ref_.x(), b = y - ref_.y(), c = z - ref_.z();
    n_ += 1.0;
    s_[0] += a, s_[1] += b, s_[2] += c;
    ss_[0] += a * a, ss_[1] += a * b, ss_[2] += a * c;
    ss_[3] += b * b, ss_[4] += b * c, ss_[5] += c * c;
  }
#endif

  Eigen::Vector3d ref_ = Eigen::Vector3d::Zero();
  bool has_ref_ = false;
  double n_ = 0.0;
#if defined(__SSE2__)
  __m128d ref_xy_ = _mm_setzero_pd();
  __m128d s_ab_ = _mm_setzero_pd(), aa_ab_ = _mm_setzero_pd(), ac_bb_ = _mm_setzero_pd(),
          bc_cc_ = _mm_setzero_pd();
  double s_c_ = 0.0;
#else
  double s_[3] = {0, 0, 0}, ss_[6] = {0, 0, 0, 0, 0, 0};
#endif
};

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

// Sequential RANSAC on a leftover component that is not one plane: the two visible faces of a
// small box or a table leg (joined at their convex edge), or a face joined to a curved surface
// by depth continuity. Extracts planes while the best hypothesis has enough inliers; a plane is
// kept only if the inliers that have a normal mostly agree with it (a band of a bowl lies
// within the tolerance of some plane but its normals fan out). Deterministic (fixed LCG).
void splitLeftoverComponent(std::vector<int> rest, const PlaneSampleGrid& grid,
                            const HoughPlaneParams& P, std::vector<PlaneHypothesis>& planes,
                            cv::Mat& sample_labels) {
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const auto* nrm = grid.normals.ptr<cv::Vec3f>(0);
  int* lab = sample_labels.ptr<int>(0);
  const PlaneTolerance& tol = P.labeling.tolerance;
  const double cos_agree = std::cos(P.leftover_normal_agreement_deg * kDegToRad);
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
      const std::size_t count = countWithin(n, d, sx, sy, sz, st, sub_n);
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
    int with_normal = 0, agreeing = 0;
    for (std::size_t k = 0; k < rest.size(); ++k) {
      const int i = rest[k];
      if (dist(best_n, best_d, i) > rest_tol[k]) {
        outliers.push_back(i);
        outlier_tol.push_back(rest_tol[k]);
        continue;
      }
      inliers.push_back(i);
      const cv::Vec3f& n = nrm[i];
      if (!(n[2] == n[2])) continue;
      ++with_normal;
      agreeing += best_n.x() * n[0] + best_n.y() * n[1] + best_n.z() * n[2] >= cos_agree;
    }
    if (static_cast<int>(inliers.size()) < P.min_plane_samples) return;
    if (with_normal >= 6 && agreeing < P.leftover_min_inlier_fraction * with_normal) return;
    const int id = static_cast<int>(planes.size());
    for (int i : inliers) lab[i] = id;
    planes.push_back({best_n, best_d});
    rest.swap(outliers);
    rest_tol.swap(outlier_tol);
  }
}

}  // namespace

NormalParams HoughPlaneParams::defaultSampleNormalParams(int step) {
  step = std::max(1, step);
  NormalParams p;
  p.method = NormalMethod::kAverage3dGradient;
  // Windows in grid cells: half-size 8 px of the full image at 1 m, growing with range.
  p.smoothing_radius_px = 8.0 / step;
  p.depth_dependent_smoothing = true;
  p.min_radius_px = 1;
  p.max_radius_px = std::max(1, 24 / step);
  // Neighbouring samples are `step` pixels apart, so the per-neighbour depth change that counts
  // as a step scales with it (1% of range per pixel: 4 cm at 1 m for step 4), and so do gaps.
  p.max_depth_change_factor = 0.01 * step;
  p.max_gap_px = std::max(1, 8 / step);
  return p;
}

struct HoughPlaneDetector::Impl {
  NormalEstimator normals_est;
  PlaneSampleGrid grid;
  HoughAccumulator raw, smooth;
  cv::Mat sample_labels;
  // Structure of arrays of the samples still free in a round (cache-friendly refinement scans).
  // fgate: the widest refinement gate of a free sample, -1 once a plane claims it (so the
  // candidate scan needs no look-up of the label).
  std::vector<int> free_idx;
  std::vector<float> fx, fy, fz, fnx, fny, fnz, ftol, fgate;
  std::vector<std::uint8_t> fin;  // candidate scan: whether a free sample passes the gates
  std::vector<float> sample_tol;  // tolerance of each sample with a normal (by sample index)
  std::vector<int> cand;          // candidates of one maximum (indices into the free arrays)
  std::vector<int> next;  // the accepted plane's final inliers (indices into the free arrays)
  std::vector<std::uint8_t> agree_across, agree_down;  // normal agreement of neighbour pairs
  // The candidates of one maximum, contiguous, and their membership flags (current / next set).
  std::vector<float> cx, cy, cz, cnx, cny, cnz, ctol;
  std::vector<std::uint8_t> calive, cin;
  std::vector<float> vx, vy, vz, vd;  // a round's votes: normal and distance of each
  std::vector<int> comp, seeds;       // leftover components: component of each sample, seeds

  explicit Impl(const HoughPlaneParams& p)
      : normals_est(p.normals), raw(p.space), smooth(p.space) {}
};

HoughPlaneDetector::HoughPlaneDetector(HoughPlaneParams params)
    : params_(params), impl_(std::make_unique<Impl>(params_)) {}
HoughPlaneDetector::~HoughPlaneDetector() = default;
HoughPlaneDetector::HoughPlaneDetector(HoughPlaneDetector&&) noexcept = default;
HoughPlaneDetector& HoughPlaneDetector::operator=(HoughPlaneDetector&&) noexcept = default;

const HoughAccumulator& HoughPlaneDetector::lastSmoothedSpace() const { return impl_->smooth; }

PlaneDetection HoughPlaneDetector::detect(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                          const cv::Mat& bgr) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  Impl& s = *impl_;
  const HoughPlaneParams& P = params_;
  const PlaneTolerance& tol = P.labeling.tolerance;

  // 1. Samples and their normals.
  s.grid.build(depth_mm, K, P.labeling.sample_step);
  if (s.grid.points.empty()) {  // a frame narrower than the sample offset: no sample, no plane
    s.sample_labels.create(s.grid.points.size(), CV_32SC1);
    return labelPlanes(depth_mm, K, bgr, s.grid, s.sample_labels, {}, P.labeling);
  }
  s.normals_est.compute(s.grid.depth_mm, s.grid.intrinsics, s.grid.normals);
  const int R = s.grid.points.rows, C = s.grid.points.cols, N = R * C;
  const auto* pts = s.grid.points.ptr<cv::Vec3f>(0);
  const auto* nrm = s.grid.normals.ptr<cv::Vec3f>(0);

  // 2. Reliable samples: the normal agrees with its 4 neighbours (planarity at sample scale).
  const float cos_spread = static_cast<float>(std::cos(P.vote_max_normal_spread_deg * kDegToRad));
  s.grid.reliable.create(R, C, CV_8UC1);
  s.grid.reliable.setTo(0);
  auto* reliable = s.grid.reliable.ptr<std::uint8_t>(0);
  // Branch-free (the four tests fail unpredictably along edges and holes). A NaN normal, own or
  // a neighbour's, makes its dot product NaN, which fails the comparison.
  // Each neighbour pair is tested once (the dot product is symmetric, bit for bit): across[i]
  // = whether sample i agrees with i + 1 (interior rows, the only ones read below; one run
  // from the second row's first sample, so the last sample of a row is compared with the next
  // row's first too, never read), down[i] = whether it agrees with i + C (every row but the
  // last).
  s.agree_across.resize(N);
  s.agree_down.resize(N);
  std::uint8_t* across = s.agree_across.data();
  std::uint8_t* down = s.agree_down.data();
  const float* nrm_flat = &nrm[0][0];
  if (R > 2) normalAgreement(nrm_flat, 1, cos_spread, C, (R - 1) * C - 1, across);
  normalAgreement(nrm_flat, C, cos_spread, 0, N - C, down);
  for (int r = 1; r + 1 < R; ++r)
    for (int c = 1; c + 1 < C; ++c) {
      const int i = r * C + c;
      reliable[i] = across[i - 1] & across[i] & down[i - C] & down[i];
    }

  s.sample_labels.create(R, C, CV_32SC1);
  s.sample_labels.setTo(-1);
  int* lab = s.sample_labels.ptr<int>(0);
  std::vector<PlaneHypothesis> planes;

  const float cos_inlier = static_cast<float>(std::cos(P.inlier_max_normal_deg * kDegToRad));
  const double peak_per_vote = s.raw.kernelPeak(P.sigma_angle_deg, P.sigma_d_m);
  const float min_peak = static_cast<float>(0.5 * P.min_plane_samples * peak_per_vote);
  const float min_block_mass = std::max(2.0f, P.min_plane_samples / 6.0f);

  // Widest gate first: the peak's d is only as good as the kernel (a parallel plane nearby
  // shifts it), so start at the kernel's spread and shrink to the sensor tolerance.
  const float wide = static_cast<float>(2.5 * P.sigma_d_m);
  std::vector<int>& cand = s.cand;
  std::vector<int>& next = s.next;
  for (auto* v :
       {&s.fx, &s.fy, &s.fz, &s.fnx, &s.fny, &s.fnz, &s.ftol, &s.fgate, &s.vx, &s.vy, &s.vz, &s.vd})
    v->resize(N);
  s.free_idx.resize(N);
  s.fin.resize(N);
  // Each sample's inlier tolerance, once per frame (tol.at costs a division; the rounds would
  // recompute it for every free sample).
  s.sample_tol.resize(N);
  for (int i = 0; i < N; ++i)
    if (nrm[i][2] == nrm[i][2]) s.sample_tol[i] = static_cast<float>(tol.at(pts[i][2]));
  // The free samples of a round, for the candidate scans (the arrays keep their size).
  const SampleArrays free_samples{s.fx.data(),  s.fy.data(),  s.fz.data(),   s.fnx.data(),
                                  s.fny.data(), s.fnz.data(), s.fgate.data()};
  for (int round = 0; round < std::max(1, P.rounds); ++round) {
    // 3. Vote with the free reliable samples; collect the free samples with normals.
    s.raw.clear();
    int votes = 0, F = 0;
    for (int i = 0; i < N; ++i) {
      if (lab[i] >= 0) continue;
      const cv::Vec3f& n = nrm[i];
      if (!(n[2] == n[2])) continue;
      const cv::Vec3f& p = pts[i];
      s.free_idx[F] = i;
      s.fx[F] = p[0], s.fy[F] = p[1], s.fz[F] = p[2];
      s.fnx[F] = n[0], s.fny[F] = n[1], s.fnz[F] = n[2];
      s.ftol[F] = s.sample_tol[i];
      s.fgate[F] = std::max(wide, 2.0f * s.ftol[F]);
      ++F;
      if (!reliable[i]) continue;
      s.vx[votes] = n[0], s.vy[votes] = n[1], s.vz[votes] = n[2];
      s.vd[votes] = -(n[0] * p[0] + n[1] * p[1] + n[2] * p[2]);
      ++votes;
    }
    s.raw.voteBatch(s.vx.data(), s.vy.data(), s.vz.data(), s.vd.data(), votes);
    if (votes < P.min_plane_samples) break;
    s.raw.smoothInto(s.smooth, P.sigma_angle_deg, P.sigma_d_m, min_block_mass, min_peak);
    const auto maxima = s.smooth.findMaxima(min_peak, P.maxima_window_a, P.maxima_window_d);

    // 4. Refine the maxima, strongest first; accepted planes claim their samples.
    int accepted = 0;
    for (int m = 0; m < std::min<int>(static_cast<int>(maxima.size()), P.max_candidates_per_round);
         ++m) {
      Eigen::Vector3d n = maxima[m].normal;
      double d = maxima[m].d;
      int num_cand = 0;  // candidates: cand[0, num_cand)
      {
        // Two branch-free loops (most samples fail, unpredictably): the tests, which
        // vectorise, then the compaction, where every index is written and only the kept ones
        // advance the end.
        // The gate is fgate itself (1 x: exact).
        const PlaneGates gates = planeGates(n, d, 1.0f, cos_inlier);
        std::uint8_t* in = s.fin.data();
        gateFlags(gates, free_samples, nullptr, in, F);
        if (cand.size() < static_cast<std::size_t>(F)) cand.resize(N);  // grows to the largest N
        int kept = 0, f = 0;
        // Most samples fail for most maxima, in long stretches: skip 8 flags at a time.
        for (; f + 8 <= F; f += 8) {
          std::uint64_t any;
          std::memcpy(&any, in + f, sizeof any);
          if (!any) continue;
          for (int t = f; t < f + 8; ++t) {
            cand[kept] = t;
            kept += in[t];
          }
        }
        for (; f < F; ++f) {
          cand[kept] = f;
          kept += in[f];
        }
        num_cand = kept;
      }
      if (num_cand == 0 || num_cand < P.min_plane_samples) continue;
      // The candidates' data, contiguous (the shrinking passes test them in loops that
      // vectorise); `alive` marks the current set, and candidateMoments skips the candidates
      // that left it.
      for (auto* v : {&s.cx, &s.cy, &s.cz, &s.cnx, &s.cny, &s.cnz, &s.ctol}) v->resize(num_cand);
      s.calive.assign(num_cand, 1);
      s.cin.resize(num_cand);
      for (int k = 0; k < num_cand; ++k) {
        const int f = cand[k];
        s.cx[k] = s.fx[f], s.cy[k] = s.fy[f], s.cz[k] = s.fz[f];
        s.cnx[k] = s.fnx[f], s.cny[k] = s.fny[f], s.cnz[k] = s.fnz[f];
        s.ctol[k] = s.ftol[f];
      }
      const float *cx = s.cx.data(), *cy = s.cy.data(), *cz = s.cz.data();
      const float *cnx = s.cnx.data(), *cny = s.cny.data(), *cnz = s.cnz.data(),
                  *ctol = s.ctol.data();
      const SampleArrays candidates{cx, cy, cz, cnx, cny, cnz, ctol};
      std::uint8_t* alive = s.calive.data();
      std::uint8_t* cin = s.cin.data();
      int first = 0;  // the first candidate of the current set
      bool ok = true;
      const int iters = std::max(1, P.refine_iterations);
      for (int it = 0; it < iters && ok; ++it) {
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
          mom = candidateMoments(ref, cx, cy, cz, nullptr, num_cand);
        } else {
          const PlaneGates gates = planeGates(n, d, it == 1 ? 2.0f : 1.0f, cos_inlier);
          gateFlags(gates, candidates, alive, cin, num_cand);
          int kept = 0;
          for (int k = 0; k < num_cand; ++k) kept += cin[k];
          if (kept == 0 || kept < P.min_plane_samples) {
            ok = false;
            break;
          }
          mom = candidateMoments(ref, cx, cy, cz, cin, num_cand);
          std::swap(alive, cin);
          while (!alive[first]) ++first;
        }
        const PlaneFit fit = mom.fit();
        if (!fit.valid) {
          ok = false;
          break;
        }
        n = fit.normal;
        d = fit.d;
      }
      if (!ok) continue;
      // Final inliers at the tolerance with the refined plane, then compacted as the
      // candidates were. (A candidate still alive passed these tests with an earlier plane:
      // its point and normal are not NaN. The plane is finite too, since fit() returns a
      // finite normal and d for finite points (the eigenvectors of a finite covariance), so no
      // comparison sees a NaN and "not rejected" is "accepted".)
      const PlaneGates final_gates = planeGates(n, d, 1.0f, cos_inlier);
      gateFlags(final_gates, candidates, alive, cin, num_cand);
      next.resize(num_cand);
      int inliers = 0;
      for (int k = 0; k < num_cand; ++k) {
        next[inliers] = cand[k];
        inliers += cin[k];
      }
      next.resize(inliers);
      if (static_cast<int>(next.size()) < P.min_plane_samples) continue;
      const int id = static_cast<int>(planes.size());
      for (int f : next) {
        lab[s.free_idx[f]] = id;
        s.fgate[f] = -1.0f;
      }
      planes.push_back({n, d});
      ++accepted;
    }
    if (accepted == 0) break;
  }

  // 5. Merge near-duplicates: the same plane found from two maxima or in two rounds, or (after
  //    step 6) a thin strip found in pieces whose separate fits disagree by a few degrees
  //    because a strip constrains its normal poorly across its width. Two planes within
  //    merge_angle_deg merge when the least-squares fit of their union is nearly as good as
  //    theirs: RMS <= max(merge_rms_factor x the worse of the two, merge_tolerance_factor x
  //    the inlier tolerance at the farther plane's mean range / 3). A box top 5 cm above the
  //    table fails by far (the union's RMS is ~2.5 cm).
  auto mergePlanes = [&]() {
    const double cos_merge = std::cos(P.merge_angle_deg * kDegToRad);
    // Moments once; a merge then adds the pair's moments and relabels at the end.
    std::vector<PlaneMoments> mom(planes.size());
    std::vector<double> zsum(planes.size(), 0.0);
    {
      // Runs of samples share a plane: its moments stay in locals until the plane changes (the
      // same additions in the same order, without a round trip through memory per sample).
      // MomentSums: PlaneMoments::add's sums in registers (the first point is the reference).
      std::vector<MomentSums> sums(planes.size());
      int cur = -1;
      MomentSums cur_sums;
      double cur_z = 0.0;
      for (int i = 0; i < N; ++i) {
        const int L = lab[i];
        if (L < 0) continue;
        if (L != cur) {
          if (cur >= 0) {
            sums[cur] = cur_sums;
            zsum[cur] = cur_z;
          }
          cur = L;
          cur_sums = sums[L];
          cur_z = zsum[L];
          if (!cur_sums.hasReference())
            cur_sums.setReference(Eigen::Vector3d(pts[i][0], pts[i][1], pts[i][2]));
        }
        cur_sums.add(pts[i]);
        cur_z += pts[i][2];
      }
      if (cur >= 0) {
        sums[cur] = cur_sums;
        zsum[cur] = cur_z;
      }
      for (std::size_t p = 0; p < planes.size(); ++p) mom[p] = sums[p].moments();
    }
    std::vector<PlaneFit> fits(planes.size());
    for (std::size_t i = 0; i < planes.size(); ++i) fits[i] = mom[i].fit();
    std::vector<int> merged_into(planes.size());
    std::iota(merged_into.begin(), merged_into.end(), 0);
    bool merged_any = false;
    // Pair scores (joint RMS / limit; infinity = no merge) are kept between iterations: a merge
    // changes only the pairs of its two planes, and each score costs an eigen-solve.
    const std::size_t P_count = planes.size();
    constexpr double kUnknown = -1.0;
    std::vector<double> score(P_count * P_count, kUnknown);
    auto pairScore = [&](std::size_t i, std::size_t j) {
      double& sc = score[i * P_count + j];
      if (sc != kUnknown) return sc;
      sc = std::numeric_limits<double>::infinity();
      if (!fits[i].valid || !fits[j].valid || fits[i].normal.dot(fits[j].normal) < cos_merge)
        return sc;
      PlaneMoments u = mom[i];
      u.merge(mom[j]);
      const PlaneFit f = u.fit();
      const double z = std::max(zsum[i] / mom[i].count(), zsum[j] / mom[j].count());
      const double limit = std::max(P.merge_rms_factor * std::max(fits[i].rms_m, fits[j].rms_m),
                                    P.merge_tolerance_factor * tol.at(z) / 3.0);
      if (f.valid && f.rms_m <= limit) sc = f.rms_m / limit;
      return sc;
    };
    for (;;) {
      double best = 1e30;
      int bi = -1, bj = -1;
      for (std::size_t i = 0; i < P_count; ++i) {
        if (!fits[i].valid) continue;
        for (std::size_t j = i + 1; j < P_count; ++j) {
          const double sc = pairScore(i, j);
          if (sc < best) {
            best = sc;
            bi = static_cast<int>(i);
            bj = static_cast<int>(j);
          }
        }
      }
      if (bi < 0) break;
      mom[bi].merge(mom[bj]);
      mom[bj] = PlaneMoments();
      zsum[bi] += zsum[bj];
      zsum[bj] = 0.0;
      fits[bi] = mom[bi].fit();
      fits[bj] = PlaneFit();
      for (std::size_t k = 0; k < P_count; ++k)
        for (const int m : {bi, bj}) score[k * P_count + m] = score[m * P_count + k] = kUnknown;
      merged_into[bj] = bi;
      merged_any = true;
      planes[bi] = {fits[bi].normal, fits[bi].d};
      planes[bj] = {Eigen::Vector3d(0, 0, -1), -1.0};  // unused from now on (no samples)
    }
    if (!merged_any) return;
    std::vector<int> survivor(planes.size());
    for (std::size_t j = 0; j < planes.size(); ++j) {
      int k = static_cast<int>(j);
      while (merged_into[k] != k) k = merged_into[k];
      survivor[j] = k;
    }
    for (int i = 0; i < N; ++i)
      if (lab[i] >= 0) lab[i] = survivor[lab[i]];
  };
  mergePlanes();

  // 6. Leftovers: thin or small surfaces (a table's front edge, a box top seen at a grazing
  //    angle, leg faces) are narrower than the normal windows plus their margin at depth steps,
  //    so they have (almost) no reliable normals and never vote. After growing the found planes
  //    over their edges, each depth-continuous component of still unassigned samples is fitted
  //    by least squares; a component that is mostly one plane (trimmed refit) becomes a plane.
  if (P.fit_leftover_components) {
    growSampleLabels(s.grid, s.sample_labels, planes, P.labeling);
    const SampleContinuity continuous(s.grid, P.labeling);
    std::vector<int>& comp = s.comp;
    comp.assign(N, -1);
    std::vector<int> stack;
    std::vector<int> members;
    std::vector<double> member_tol;
    // The possible seeds (unassigned, valid) first, in a branch-free pass: a sample labelled
    // by an earlier component below was one of its members, which the comp test skips.
    std::vector<int>& seeds = s.seeds;
    seeds.resize(N);
    int seed_count = 0;
    for (int i = 0; i < N; ++i) {
      seeds[seed_count] = i;
      seed_count += (lab[i] < 0) & (pts[i][2] > 0);
    }
    for (int q = 0; q < seed_count; ++q) {
      const int seed = seeds[q];
      if (comp[seed] >= 0) continue;
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
      if (static_cast<int>(members.size()) < P.min_plane_samples) continue;
      PlaneMoments mom;
      for (int i : members) mom.add(pts[i][0], pts[i][1], pts[i][2]);
      PlaneFit fit = mom.fit();
      member_tol.resize(members.size());  // tested by every trimming pass
      for (std::size_t k = 0; k < members.size(); ++k) member_tol[k] = tol.at(pts[members[k]][2]);
      std::size_t inl = 0;
      for (int it = 0; it < 3 && fit.valid; ++it) {
        // Trim: first pass keeps points within 3x the tolerance, then within the tolerance.
        const double mult = it == 0 ? 3.0 : 1.0;
        PlaneMoments m2;
        inl = 0;
        for (std::size_t k = 0; k < members.size(); ++k) {
          const int i = members[k];
          const double dist = std::fabs(fit.normal.x() * pts[i][0] + fit.normal.y() * pts[i][1] +
                                        fit.normal.z() * pts[i][2] + fit.d);
          if (dist > mult * member_tol[k]) continue;
          m2.add(pts[i][0], pts[i][1], pts[i][2]);
          ++inl;
        }
        fit = m2.fit();
      }
      if (!fit.valid || static_cast<int>(inl) < P.min_plane_samples ||
          static_cast<double>(inl) <
              P.leftover_min_inlier_fraction * static_cast<double>(members.size())) {
        if (P.leftover_ransac_hypotheses > 0)
          splitLeftoverComponent(members, s.grid, P, planes, s.sample_labels);
        continue;
      }
      const int id = static_cast<int>(planes.size());
      for (std::size_t k = 0; k < members.size(); ++k) {
        const int i = members[k];
        const double dist = std::fabs(fit.normal.x() * pts[i][0] + fit.normal.y() * pts[i][1] +
                                      fit.normal.z() * pts[i][2] + fit.d);
        if (dist <= member_tol[k]) lab[i] = id;
      }
      planes.push_back({fit.normal, fit.d});
    }
    mergePlanes();
  }

  // 7. Full-resolution labels, regions, refits, polygons.
  return labelPlanes(depth_mm, K, bgr, s.grid, s.sample_labels, planes, P.labeling);
}

}  // namespace shapesense
