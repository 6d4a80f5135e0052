#include "shapesense/core/planes/plane_labeling.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>

#include "shapesense/core/planes/plane_polygon.h"

#include "planes/planes_kernels.h"

namespace shapesense {
namespace {

int findRoot(int* parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

void unite(int* parent, int a, int b) {
  a = findRoot(parent, a);
  b = findRoot(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

// Calls f(c) for each c in [0, n) with flags[c] != 0, in order. Set flags are expected to be
// few: they are scanned eight at a time (flags must hold n rounded up to whole words of eight).
template <typename F>
inline void forEachSetFlag(const std::uint8_t* flags, int n, F&& f) {
  for (int c0 = 0; c0 < n; c0 += 8) {
    std::uint64_t word;
    std::memcpy(&word, flags + c0, sizeof word);
    if (word == 0) continue;
    for (int c = c0; c < std::min(c0 + 8, n); ++c)
      if (flags[c]) f(c);
  }
}

struct RegionAccumulator {
  int plane = -1;  // index into the hypotheses
  int samples = 0;
  cv::Rect sample_box;  // on the sample grid
  // Full-resolution accumulation: raw moments (camera frame, in double: the covariance of a
  // region metres away keeps ~8 significant digits), added run by run.
  PlaneMoments moments{Eigen::Vector3d::Zero()};
  std::size_t count = 0;
  int u0 = std::numeric_limits<int>::max(), v0 = std::numeric_limits<int>::max(), u1 = -1, v1 = -1;
  std::array<std::uint64_t, 3> colour{};
};

// The regions a sample's pixels may take: the distinct regions of its 3x3 sample
// neighbourhood, its own first, -1 terminated (at most 4).
using CandidateList = std::array<int, 4>;

// Summary of a set of region ids: -1 none (only unlabelled samples), -2 several, else the one
// region.
inline int mergeRegionSummary(int a, int b) {
  // Selects, not branches: along region borders the cases alternate unpredictably.
  const int same_or_none = (b == -1) | (a == b);
  const int ab = same_or_none ? a : -2;
  return a == -1 ? b : ab;
}

// Element-wise, without the library call std::array's == makes of it (one per sample).
inline bool sameCandidates(const CandidateList& a, const CandidateList& b) {
  return a[0] == b[0] && a[1] == b[1] && a[2] == b[2] && a[3] == b[3];
}

// A horizontal run of pixels of one image row whose samples share one candidate list.
struct PixelRun {
  int u0 = 0, u1 = 0;  // [u0, u1)
  CandidateList list{};
};

// The candidate runs of every sample row, kept for the renumbering at the end.
struct LabelRuns {
  std::vector<PixelRun> runs;
  std::vector<int> row_begin;   // runs of sample row r: [row_begin[r], row_begin[r + 1])
  std::vector<int> row_sample;  // sample row of each image row
};

// The candidate runs of every sample row: horizontal runs of pixels whose samples share one
// candidate list (the distinct regions of the sample's 3x3 neighbourhood, its own first, -1
// terminated, at most 4); consecutive samples with equal lists merge, so a row crossing one
// plane is a single run, and samples without a candidate make no run (their pixels stay 0).
// sample_u0/u1: pixel range of each sample column. Most neighbourhoods hold at most one region
// (inside a region, or a region next to unlabelled samples): found from summaries of the rows
// of three, they extend the current run without building a list.
void buildCandidateRuns(const int* region_of, int R, int C, const std::vector<int>& sample_u0,
                        const std::vector<int>& sample_u1, LabelRuns& lr) {
  // Row summaries of rows -1 .. R (the two outside rows summarise nothing: -1), then the
  // summary of each 3x3 neighbourhood of the current row; boundary-free loops that vectorise.
  std::vector<int> row_summary(static_cast<std::size_t>(R + 3) * C, -1);
  int* const one_row = &row_summary[static_cast<std::size_t>(R + 2) * C];
  for (int r = 0; r < R; ++r) {
    const int* reg = &region_of[static_cast<std::size_t>(r) * C];
    int* sum = &row_summary[static_cast<std::size_t>(r + 1) * C];
    if (C == 1) {
      sum[0] = reg[0];
      continue;
    }
    sum[0] = mergeRegionSummary(reg[0], reg[1]);  // merge(-1, a) == a
    for (int c = 1; c + 1 < C; ++c)
      sum[c] = mergeRegionSummary(mergeRegionSummary(reg[c - 1], reg[c]), reg[c + 1]);
    sum[C - 1] = mergeRegionSummary(reg[C - 2], reg[C - 1]);  // merge(a, -1) == a
  }
  // Whether every sample column has pixels and each starts where the previous one ends.
  bool tiled = true;
  for (int c = 0; c < C; ++c)
    tiled &= sample_u0[c] < sample_u1[c] && (c == 0 || sample_u0[c] == sample_u1[c - 1]);
  lr.runs.clear();
  lr.row_begin.assign(R + 1, 0);
  for (int r = 0; r < R; ++r) {
    const std::size_t row_first = lr.runs.size();
    const int* mid = &row_summary[static_cast<std::size_t>(r + 1) * C];
    const int *above = mid - C, *below = mid + C;
    for (int c = 0; c < C; ++c)
      one_row[c] = mergeRegionSummary(mergeRegionSummary(above[c], mid[c]), below[c]);
    for (int c = 0; c < C; ++c) {
      const int u0 = sample_u0[c], u1 = sample_u1[c];
      if (u0 >= u1) continue;
      const int one = one_row[c];
      if (one != -2) {
        // One candidate (or none): extends a single-candidate run of the same region. When the
        // samples tile the row, the following samples with the same summary would each extend
        // it (or, without a candidate, be skipped): take them all at once.
        int last = c;
        if (tiled)
          while (last + 1 < C && one_row[last + 1] == one) ++last;
        const int u1_last = sample_u1[last];
        c = last;
        if (lr.runs.size() > row_first) {
          PixelRun& back = lr.runs.back();
          if (back.list[0] == one && back.list[1] < 0 && back.u1 == u0) {
            back.u1 = u1_last;
            continue;
          }
        }
        if (one < 0) continue;  // no candidate: the pixels stay 0
        lr.runs.push_back({u0, u1_last, {one, -1, -1, -1}});
        continue;
      }
      const int i = r * C + c;
      CandidateList list;
      list.fill(-1);
      const int own = region_of[i];
      list[0] = own;
      const int r0 = std::max(r - 1, 0), r1 = std::min(r + 1, R - 1), c0 = std::max(c - 1, 0),
                c1 = std::min(c + 1, C - 1);
      int n = own >= 0 ? 1 : 0;
      for (int rr = r0; rr <= r1; ++rr)
        for (int cc = c0; cc <= c1; ++cc) {
          const int reg = region_of[rr * C + cc];
          if (reg < 0 || n == 4 ||
              std::find(list.begin(), list.begin() + n, reg) != list.begin() + n)
            continue;
          list[n++] = reg;
        }
      if (lr.runs.size() > row_first) {
        PixelRun& back = lr.runs.back();
        if (sameCandidates(back.list, list) && back.u1 == u0) {
          back.u1 = u1;
          continue;
        }
      }
      if (list[0] < 0) continue;
      lr.runs.push_back({u0, u1, list});
    }
    lr.row_begin[r + 1] = static_cast<int>(lr.runs.size());
  }
}

// Pinhole form of the plane distance: a pixel (u, v) with depth z is z (A u + B v + C) + D from
// the plane (floats; coef holds A, B, C, D per region).
std::vector<float> pixelPlaneCoefficients(const std::vector<RegionAccumulator>& regions,
                                          const std::vector<PlaneHypothesis>& planes,
                                          const CameraIntrinsics& K) {
  std::vector<float> coef(4 * regions.size());
  for (std::size_t k = 0; k < regions.size(); ++k) {
    const auto& h = planes[regions[k].plane];
    coef[4 * k + 0] = static_cast<float>(h.normal.x() / K.fx);
    coef[4 * k + 1] = static_cast<float>(h.normal.y() / K.fy);
    coef[4 * k + 2] =
        static_cast<float>(h.normal.z() - h.normal.x() * K.cx / K.fx - h.normal.y() * K.cy / K.fy);
    coef[4 * k + 3] = static_cast<float>(h.d);
  }
  return coef;
}

// Region reg's plane in the pinhole form of the labelling kernels, for pixel row fv.
planes_kernels::PixelPlane pixelPlane(const std::vector<float>& coef,
                                      const std::vector<float>& region_tol, int reg, float fv) {
  const float* q = &coef[4 * reg];
  return {q[0], q[1] * fv, q[2], q[3], region_tol[reg]};
}

// Pixel count and bounds of one region in one row.
struct RowSpan {
  int n = 0, first = std::numeric_limits<int>::max(), last = -1;
};

void addRowSpan(RegionAccumulator& reg, const RowSpan& span, int v) {
  if (!span.n) return;
  reg.count += static_cast<std::size_t>(span.n);
  reg.u0 = std::min(reg.u0, span.first);
  reg.u1 = std::max(reg.u1, span.last);
  reg.v0 = std::min(reg.v0, v);
  reg.v1 = std::max(reg.v1, v);
}

// Labels the pixels of a run (the closest candidate plane within its tolerance, 0 where there
// is none); counts[k]: pixels labelled with candidate k (the runs' spans need them).
void labelRun(const std::uint16_t* drow, std::uint16_t* lrow, const PixelRun& run,
              const std::vector<float>& coef, float fv, const std::vector<float>& region_tol,
              float tol_floor, std::array<int, 4>& counts) {
  counts.fill(0);
  if (run.list[1] < 0) {
    counts[0] = planes_kernels::labelSingleCandidateRun(
        drow, lrow, run.u0, run.u1, pixelPlane(coef, region_tol, run.list[0], fv), tol_floor,
        static_cast<std::uint16_t>(run.list[0] + 1));
    return;
  }
  planes_kernels::PixelPlane candidates[4];
  std::uint16_t labels[4];
  int k = 0;
  for (; k < 4 && run.list[k] >= 0; ++k) {
    candidates[k] = pixelPlane(coef, region_tol, run.list[k], fv);
    labels[k] = static_cast<std::uint16_t>(run.list[k] + 1);
  }
  planes_kernels::labelCandidatesRun(drow, lrow, run.u0, run.u1, candidates, labels, k, tol_floor,
                                     counts.data());
}

// Pixel span of the pixels labelled `label` in lrow[u0, u1); `count` of them when known (-1:
// count them).
RowSpan runSpan(const std::uint16_t* lrow, int u0, int u1, std::uint16_t label, int count = -1) {
  RowSpan span;
  span.n = count;
  if (count < 0) {
    span.n = 0;
    for (int u = u0; u < u1; ++u) span.n += lrow[u] == label;  // vectorises
  }
  if (!span.n) return span;
  span.first = u0;
  span.last = u1 - 1;
  while (lrow[span.first] != label) ++span.first;
  while (lrow[span.last] != label) --span.last;
  return span;
}

// Moments and colour are accumulated on every kMomentStride-th pixel of every kMomentStride-th
// row (see labelPixels).
constexpr int kMomentStride = 2;

// The first pixel column >= u0 on the moment lattice.
inline int firstMomentPixel(int u0) {
  return (u0 + kMomentStride - 1) / kMomentStride * kMomentStride;
}

// The six sums of a run's moments (see addRunMoments).
struct RunSums {
  double n = 0, sz = 0, szz = 0, sxz = 0, sxzz = 0, sxxzz = 0;
  void add(double z, double xr) {
    const double xz = xr * z;
    n += 1.0;
    sz += z;
    szz += z * z;
    sxz += xz;
    sxzz += xz * z;
    sxxzz += xz * xz;
  }
  void add(const RunSums& o) {
    n += o.n;
    sz += o.sz;
    szz += o.szz;
    sxz += o.sxz;
    sxzz += o.sxzz;
    sxxzz += o.sxxzz;
  }
};

// Colour sums of a run (locals: stores through a uchar row could alias the region).
struct RunColour {
  std::uint64_t b = 0, g = 0, r = 0;
  void add(const cv::Vec3b& c) {
    b += c[0];
    g += c[1];
    r += c[2];
  }
};

// Adds the pixels labelled `label` in lrow[u0, u1) on the moment lattice to the moments and colour
// of their region. In the pixel's own terms x = xr(u) z and y = yr z, so the run needs only six
// sums (yr is constant along it) and the loop keeps them in registers. The colour is summed in
// the same pass (one test of the label per pixel). Alternate lattice pixels go to two sets of
// sums: each sum is a chain of dependent additions, and two chains run in parallel. kColour:
// whether there is a colour row (a template parameter: no test of it per pixel).
template <bool kColour>
void addRunMoments(const std::uint16_t* drow, const std::uint16_t* lrow, const cv::Vec3b* crow,
                   int u0, int u1, std::uint16_t label, const double* xr, double yr,
                   RegionAccumulator& reg) {
  RunSums even, odd;
  RunColour colour;
  int u = firstMomentPixel(u0);
  for (; u + kMomentStride < u1; u += 2 * kMomentStride) {
    const int u2 = u + kMomentStride;
    if (lrow[u] == label) {
      even.add(drow[u] * 0.001, xr[u]);
      if constexpr (kColour) colour.add(crow[u]);
    }
    if (lrow[u2] == label) {
      odd.add(drow[u2] * 0.001, xr[u2]);
      if constexpr (kColour) colour.add(crow[u2]);
    }
  }
  if (u < u1 && lrow[u] == label) {
    even.add(drow[u] * 0.001, xr[u]);
    if constexpr (kColour) colour.add(crow[u]);
  }
  even.add(odd);
  const double n = even.n, sz = even.sz, szz = even.szz, sxz = even.sxz, sxzz = even.sxzz,
               sxxzz = even.sxxzz;
  if (n == 0) return;
  Eigen::Matrix3d sum_sq;  // upper triangle
  sum_sq << sxxzz, yr * sxzz, sxzz, 0.0, yr * yr * szz, yr * szz, 0.0, 0.0, szz;
  reg.moments.addSums(n, Eigen::Vector3d(sxz, yr * sz, sz), sum_sq);
  reg.colour[0] += colour.b;
  reg.colour[1] += colour.g;
  reg.colour[2] += colour.r;
}

// Every full-resolution pixel takes the closest candidate plane of its sample within the
// tolerance. Moments and colour are accumulated on every second pixel of every second row: a
// quarter of a region's pixels fit its plane as well as all of them (the fit error is dominated
// by the correlated quantisation pattern, not by the pixel count) at a quarter of the cost.
// Work goes by runs of pixels sharing one candidate list; inside a region that is one plane, so
// the common case is a tight single-plane loop.
LabelRuns labelPixels(const cv::Mat& depth_mm, const CameraIntrinsics& K, const cv::Mat& bgr,
                      const PlaneSampleGrid& grid, const int* region_of,
                      const std::vector<PlaneHypothesis>& planes,
                      const std::vector<float>& region_tol, float tol_floor,
                      std::vector<RegionAccumulator>& regions, cv::Mat& labels) {
  const int R = grid.points.rows, C = grid.points.cols, step = grid.step, off = grid.offset;
  const std::vector<float> coef = pixelPlaneCoefficients(regions, planes, K);
  labels.create(depth_mm.size(), CV_16UC1);  // every pixel is written below: by a run or as a gap
  // The nearest sample, halves rounded up (lround((x - off) / step), clamped; integer arithmetic:
  // below the first sample both give 0 after the clamp).
  auto sampleOf = [&](int x, int n) {
    const int xo = x - off;
    return std::clamp(xo < 0 ? 0 : (2 * xo + step) / (2 * step), 0, n - 1);
  };
  // Pixel columns of each sample column (contiguous: the mapping is monotonic).
  std::vector<int> sample_u0(C, 0), sample_u1(C, 0);
  for (int u = depth_mm.cols - 1; u >= 0; --u) sample_u0[sampleOf(u, C)] = u;
  for (int u = 0; u < depth_mm.cols; ++u) sample_u1[sampleOf(u, C)] = u + 1;
  LabelRuns lr;
  buildCandidateRuns(region_of, R, C, sample_u0, sample_u1, lr);
  lr.row_sample.resize(depth_mm.rows);
  for (int v = 0; v < depth_mm.rows; ++v) lr.row_sample[v] = sampleOf(v, R);
  std::vector<double> xr(depth_mm.cols);
  for (int u = 0; u < depth_mm.cols; ++u) xr[u] = (u - K.cx) / K.fx;
  for (int v = 0; v < depth_mm.rows; ++v) {
    const int r = lr.row_sample[v];
    const auto* drow = depth_mm.ptr<std::uint16_t>(v);
    auto* lrow = labels.ptr<std::uint16_t>(v);
    const float fv = static_cast<float>(v);
    const cv::Vec3b* crow =
        !bgr.empty() && v % kMomentStride == 0 ? bgr.ptr<cv::Vec3b>(v) : nullptr;
    const double yr = (v - K.cy) / K.fy;
    int gap_u0 = 0;
    for (int k = lr.row_begin[r]; k < lr.row_begin[r + 1]; ++k) {
      const PixelRun& run = lr.runs[k];
      std::fill(lrow + gap_u0, lrow + run.u0, std::uint16_t{0});  // pixels without a candidate
      gap_u0 = run.u1;
      std::array<int, 4> counts;  // pixels labelled with each candidate
      labelRun(drow, lrow, run, coef, fv, region_tol, tol_floor, counts);
      for (int slot = 0; slot < 4 && run.list[slot] >= 0; ++slot) {
        const auto label = static_cast<std::uint16_t>(run.list[slot] + 1);
        auto& reg = regions[run.list[slot]];
        addRowSpan(reg, runSpan(lrow, run.u0, run.u1, label, counts[slot]), v);
        if (v % kMomentStride == 0) {
          if (crow)
            addRunMoments<true>(drow, lrow, crow, run.u0, run.u1, label, xr.data(), yr, reg);
          else
            addRunMoments<false>(drow, lrow, crow, run.u0, run.u1, label, xr.data(), yr, reg);
        }
      }
    }
    std::fill(lrow + gap_u0, lrow + depth_mm.cols, std::uint16_t{0});
  }
  return lr;
}

// Applies `lut` (new label of each label; lut[l] <= l) to the labelled pixels, run by run: a
// single-candidate run holds one label, so its pixels are rewritten without a look-up.
void renumberLabels(cv::Mat& labels, const LabelRuns& lr, const std::vector<std::uint16_t>& lut) {
  for (int v = 0; v < labels.rows; ++v) {
    auto* l = labels.ptr<std::uint16_t>(v);
    const int r = lr.row_sample[v];
    for (int k = lr.row_begin[r]; k < lr.row_begin[r + 1]; ++k) {
      const PixelRun& run = lr.runs[k];
      if (run.list[1] < 0) {
        const std::uint16_t from = static_cast<std::uint16_t>(run.list[0] + 1), to = lut[from];
        if (to == from) continue;
        for (int u = run.u0; u < run.u1; ++u) l[u] = static_cast<std::uint16_t>((l[u] != 0) * to);
        continue;
      }
      for (int u = run.u0; u < run.u1; ++u) l[u] = lut[l[u]];
    }
  }
}

}  // namespace

std::vector<float> planeToleranceCoefficients(const PlaneSampleGrid& grid,
                                              const cv::Mat& sample_labels,
                                              const std::vector<PlaneHypothesis>& planes,
                                              const PlaneLabelingParams& params) {
  const PlaneTolerance& tol = params.tolerance;
  const std::size_t planes_count = planes.size();
  const double step1 = tol.noise.depthStep(1.0);  // depth step at 1 m; depthStep(z) = step1 z^2
  std::vector<float> coef(planes_count, static_cast<float>(tol.noise_steps * step1));
  if (!(params.adaptive_tolerance_factor > 0.0)) return coef;
  std::vector<double> sum(planes_count, 0.0);
  std::vector<int> count(planes_count, 0);
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  const int* lab = sample_labels.ptr<int>(0);
  // Consecutive samples mostly share a plane: its sum, count and coefficients stay in registers
  // until the plane changes (the same additions in the same order as sum[L] += ..., without a
  // store-to-load round trip per sample).
  int cur = -1, cur_count = 0;
  double cur_sum = 0.0, nx = 0.0, ny = 0.0, nz = 0.0, d = 0.0;
  for (int i = 0; i < grid.points.rows * grid.points.cols; ++i) {
    const int L = lab[i];
    if (L < 0 || static_cast<std::size_t>(L) >= planes_count) continue;
    if (L != cur) {
      if (cur >= 0) {
        sum[cur] = cur_sum;
        count[cur] = cur_count;
      }
      cur = L;
      cur_sum = sum[L];
      cur_count = count[L];
      const auto& h = planes[L];
      nx = h.normal.x();
      ny = h.normal.y();
      nz = h.normal.z();
      d = h.d;
    }
    const cv::Vec3f& p = pts[i];
    const double r = (nx * p[0] + ny * p[1] + nz * p[2] + d) / (step1 * p[2] * p[2]);
    cur_sum += r * r;
    ++cur_count;
  }
  if (cur >= 0) {
    sum[cur] = cur_sum;
    count[cur] = cur_count;
  }
  const double lo = std::min(params.min_tolerance_steps, tol.noise_steps);
  for (std::size_t L = 0; L < planes_count; ++L) {
    if (count[L] < 6) continue;  // too few to tell: keep the full tolerance
    const double steps = std::clamp(params.adaptive_tolerance_factor * std::sqrt(sum[L] / count[L]),
                                    lo, tol.noise_steps);
    coef[L] = static_cast<float>(steps * step1);
  }
  return coef;
}

void PlaneSampleGrid::build(const cv::Mat& depth_full_mm, const CameraIntrinsics& full,
                            int sample_step) {
  CV_Assert(depth_full_mm.type() == CV_16UC1);
  step = std::max(1, sample_step);
  offset = step / 2;
  const int rows = (depth_full_mm.rows - offset + step - 1) / step;
  const int cols = (depth_full_mm.cols - offset + step - 1) / step;
  depth_mm.create(rows, cols, CV_16UC1);
  points.create(rows, cols, CV_32FC3);
  intrinsics = full;
  intrinsics.fx = full.fx / step;
  intrinsics.fy = full.fy / step;
  intrinsics.cx = (full.cx - offset) / step;
  intrinsics.cy = (full.cy - offset) / step;
  intrinsics.width = cols;
  intrinsics.height = rows;
  const float ifx = static_cast<float>(1.0 / full.fx), ify = static_cast<float>(1.0 / full.fy);
  // x = rx z with rx = (u - cx) / fx, the same in every row.
  std::vector<float> rx(static_cast<std::size_t>(std::max(cols, 0)));
  for (int c = 0; c < cols; ++c)
    rx[c] = (static_cast<float>(offset + c * step) - static_cast<float>(full.cx)) * ifx;
  for (int r = 0; r < rows; ++r) {
    const int v = offset + r * step;
    const auto* src = depth_full_mm.ptr<std::uint16_t>(v);
    auto* d = depth_mm.ptr<std::uint16_t>(r);
    const float ry = (static_cast<float>(v) - static_cast<float>(full.cy)) * ify;
    for (int c = 0; c < cols; ++c) d[c] = src[offset + c * step];
    planes_kernels::sampleRowPoints(d, rx.data(), ry, cols, points.ptr<float>(r));
  }
}

namespace {

// growSampleLabels with the planes' tolerance coefficients already computed.
void growSampleLabels(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                      const std::vector<PlaneHypothesis>& planes, const PlaneLabelingParams& params,
                      const std::vector<float>& tol_coef) {
  const int R = grid.points.rows, C = grid.points.cols;
  const PlaneTolerance& tol = params.tolerance;
  auto point = [&](int i) -> const cv::Vec3f& { return grid.points.ptr<cv::Vec3f>(0)[i]; };
  int* lab = sample_labels.ptr<int>(0);
  auto dist = [&](int plane, const cv::Vec3f& p) {
    const auto& h = planes[plane];
    return static_cast<float>(h.normal.x() * p[0] + h.normal.y() * p[1] + h.normal.z() * p[2] +
                              h.d);
  };
  const bool with_normals =
      grid.normals.size() == grid.points.size() && grid.reliable.size() == grid.points.size();
  const double cos_gate = std::cos(params.grow_max_normal_deg * 3.14159265358979323846 / 180.0);
  const double cos_unreliable =
      std::cos(params.grow_max_unreliable_normal_deg * 3.14159265358979323846 / 180.0);
  const float tol_floor = static_cast<float>(tol.floor_m);
  const SampleContinuity continuous(grid, params);
  // The queue holds (row, column) pairs (r << 16 | c): the index is r C + c, while recovering
  // r and c from the index would cost two integer divisions per entry. Every sample enters it
  // at most once.
  CV_Assert(R <= 0xFFFF && C <= 0xFFFF);
  // Not zeroed: only the entries below tail are read, each written first.
  const auto queue =
      std::make_unique_for_overwrite<std::uint32_t[]>(static_cast<std::size_t>(R) * C);
  std::size_t tail = 0;
  // Seeds: the labelled samples with an unlabelled valid 4-neighbour, in index order. The
  // others could never take a neighbour, so the growth is that of seeding every labelled sample.
  // Whether each sample is open (unlabelled and valid) first, in one branch-free pass, on a
  // grid with a closed one-sample border; the seed test then ORs four flags without bounds
  // tests, into a row of seed flags (a branch-free pass that vectorises). Seeds are few (they
  // line the borders of the labelled areas): the flags are scanned eight at a time.
  const int W = C + 2;
  std::vector<std::uint8_t> open(static_cast<std::size_t>(R + 2) * W, 0);
  for (int r = 0; r < R; ++r) {
    const int* lrow = lab + r * C;
    const cv::Vec3f* prow = &point(r * C);
    std::uint8_t* orow = &open[static_cast<std::size_t>(r + 1) * W + 1];
    for (int c = 0; c < C; ++c)
      orow[c] = static_cast<std::uint8_t>((lrow[c] == -1) & (prow[c][2] > 0));
  }
  std::vector<std::uint8_t> seed(static_cast<std::size_t>(C) + 8, 0);  // one row, whole words
  for (int r = 0; r < R; ++r) {
    const int* lrow = lab + r * C;
    const std::uint8_t* orow = &open[static_cast<std::size_t>(r + 1) * W + 1];
    for (int c = 0; c < C; ++c) {
      const int any = orow[c - 1] | orow[c + 1] | orow[c - W] | orow[c + W];
      seed[c] = static_cast<std::uint8_t>((lrow[c] >= 0) & (any != 0));
    }
    forEachSetFlag(seed.data(), C, [&](int c) {
      queue[tail++] = static_cast<std::uint32_t>(r) << 16 | static_cast<std::uint32_t>(c);
    });
  }
  for (std::size_t q = 0; q < tail; ++q) {
    const int r = static_cast<int>(queue[q] >> 16), c = static_cast<int>(queue[q] & 0xFFFF);
    const int i = r * C + c, L = lab[i];
    const float z = point(i)[2];
    const int nbr[4] = {c > 0 ? i - 1 : -1, c + 1 < C ? i + 1 : -1, r > 0 ? i - C : -1,
                        r + 1 < R ? i + C : -1};
    const std::uint32_t nbr_rc[4] = {queue[q] - 1, queue[q] + 1, queue[q] - (1u << 16),
                                     queue[q] + (1u << 16)};
    for (int t = 0; t < 4; ++t) {
      const int j = nbr[t];
      if (j < 0 || lab[j] != -1) continue;
      const cv::Vec3f& p = point(j);
      if (!(p[2] > 0) || !continuous(z, p[2])) continue;
      if (std::fabs(dist(L, p)) > std::max(tol_floor, tol_coef[L] * p[2] * p[2])) continue;
      if (with_normals) {
        const cv::Vec3f& n = grid.normals.ptr<cv::Vec3f>(0)[j];
        const auto& h = planes[L].normal;
        const double c = grid.reliable.ptr<std::uint8_t>(0)[j] ? cos_gate : cos_unreliable;
        if (h.x() * n[0] + h.y() * n[1] + h.z() * n[2] < c) continue;  // NaN normals pass
      }
      lab[j] = L;
      queue[tail++] = nbr_rc[t];
    }
  }
}

}  // namespace

void growSampleLabels(const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                      const std::vector<PlaneHypothesis>& planes,
                      const PlaneLabelingParams& params) {
  growSampleLabels(grid, sample_labels, planes, params,
                   planeToleranceCoefficients(grid, sample_labels, planes, params));
}

PlaneDetection labelPlanes(const cv::Mat& depth_mm, const CameraIntrinsics& K, const cv::Mat& bgr,
                           const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                           const std::vector<PlaneHypothesis>& planes,
                           const PlaneLabelingParams& params) {
  CV_Assert(depth_mm.type() == CV_16UC1 && sample_labels.type() == CV_32SC1 &&
            sample_labels.size() == grid.points.size());
  const int R = grid.points.rows, C = grid.points.cols, step = grid.step, off = grid.offset;
  if (R == 0 || C == 0) {  // a frame narrower than the sample offset holds no sample
    PlaneDetection none;
    none.labels = cv::Mat::zeros(depth_mm.size(), CV_16UC1);
    return none;
  }
  const PlaneTolerance& tol = params.tolerance;
  const float tol_floor = static_cast<float>(tol.floor_m);
  const SampleContinuity continuous(grid, params);
  auto point = [&](int i) -> const cv::Vec3f& { return grid.points.ptr<cv::Vec3f>(0)[i]; };
  int* lab = sample_labels.ptr<int>(0);

  const std::vector<float> tol_coef =
      planeToleranceCoefficients(grid, sample_labels, planes, params);
  growSampleLabels(grid, sample_labels, planes, params, tol_coef);
  // 2. Connected regions (same plane, 4-connected, depth-continuous).
  // The per-sample arrays below are not zeroed where every entry read is written first (zeroing
  // them cost as much as some of the passes over them).
  const std::size_t samples = static_cast<std::size_t>(R) * C;
  const auto parent_storage = std::make_unique_for_overwrite<int[]>(samples);
  int* const parent = parent_storage.get();
  std::iota(parent, parent + samples, 0);
  if (params.split_connected_regions) {
    // Which joins were made (bit 0: with the left neighbour, bit 1: with the one above). When
    // i joined its left neighbour, which joined the sample above it, which joined its own left
    // neighbour (the one above i), then i and the one above are already in one set and that
    // join is skipped; inside a region that is almost every sample.
    // root: the root (smallest index) of the set of the sample just processed. No set changes
    // between that sample and the next, so a join with the left neighbour takes it without a
    // find.
    // Written for every labelled sample; read only for labelled ones.
    const auto joined = std::make_unique_for_overwrite<std::uint8_t[]>(samples);
    // The joins of each sample of a row (same bits), found first in branch-free passes over the
    // row's depths copied to a contiguous array (they vectorise); the union-find pass only
    // reads them. A sample with another label than its neighbour does not join it (two
    // unlabelled neighbours may get a bit: they are never read).
    std::vector<float> z_row(C), z_above(C);
    std::vector<std::uint8_t> can_join(C);
    int root = -1;
    for (int r = 0; r < R; ++r) {
      const int* lrow = lab + static_cast<std::ptrdiff_t>(r) * C;
      for (int c = 0; c < C; ++c) z_row[c] = point(r * C + c)[2];
      can_join[0] = 0;
      for (int c = 1; c < C; ++c)
        can_join[c] =
            static_cast<std::uint8_t>(static_cast<int>(lrow[c] == lrow[c - 1]) &
                                      static_cast<int>(continuous(z_row[c], z_row[c - 1])));
      if (r > 0) {
        const int* above = lrow - C;
        for (int c = 0; c < C; ++c)
          can_join[c] |=
              static_cast<std::uint8_t>((static_cast<int>(lrow[c] == above[c]) &
                                         static_cast<int>(continuous(z_row[c], z_above[c])))
                                        << 1);
      }
      for (int c = 0; c < C; ++c) {
        const int i = r * C + c;
        if (lab[i] < 0) continue;
        const int can = can_join[c];
        int own = i;  // i is still its own root here (raster order)
        joined[i] = static_cast<std::uint8_t>(can);
        if (can & 1) parent[i] = own = root;
        if (can & 2) {
          const bool linked = (can & 1) && (joined[i - 1] & 2) && (joined[i - C] & 1);
          if (!linked) {
            // unite(i, i - C), with the find of i known.
            const int above = findRoot(parent, i - C);
            if (above != own) {
              parent[std::max(own, above)] = std::min(own, above);
              own = std::min(own, above);
            }
          }
        }
        root = own;
      }
      std::swap(z_row, z_above);
    }
  }
  // Pieces of one plane separated only by things in front of it (a floor seen between table
  // legs, a wall behind a box) are one surface: SegComp truth and users both see one floor.
  // Pieces separated by surface *behind* the plane (two box tops at the same height, with the
  // table between them) are distinct surfaces. Test: walk the image line between the pieces'
  // centroids; it may cross the plane's own pieces, holes and occluders, but (almost) no sample
  // farther along its ray than the plane.
  if (params.split_connected_regions && params.merge_occluded_pieces) {
    const int min_piece = std::max(1, params.min_region_pixels / (2 * step * step));
    // Sample count and row / column sums of each piece (a sum reaches R C max(R, C): 64 bits),
    // at its root: the root is the piece's smallest index, so its first sample in raster order,
    // where the sums start (only roots are read).
    const auto cnt = std::make_unique_for_overwrite<int[]>(samples);
    const auto sr = std::make_unique_for_overwrite<std::int64_t[]>(samples);
    const auto sc = std::make_unique_for_overwrite<std::int64_t[]>(samples);
    // parent[i] <= i (unite keeps the smaller root), so one forward pass leaves every entry
    // pointing at its root (the roots stay the same: no find is needed below). Consecutive
    // samples mostly share a root: its sums stay in registers until the root changes.
    int cur = -1, cur_n = 0;
    std::int64_t cur_r = 0, cur_c = 0;
    std::vector<int> roots;  // of the labelled pieces, in index order
    for (int r = 0, i = 0; r < R; ++r)
      for (int c = 0; c < C; ++c, ++i) {
        const int root = parent[parent[i]];
        parent[i] = root;
        if (lab[i] < 0) continue;
        if (root != cur) {
          if (cur >= 0) {
            cnt[cur] = cur_n;
            sr[cur] = cur_r;
            sc[cur] = cur_c;
          }
          cur = root;
          const bool first = root == i;
          if (first) roots.push_back(i);
          cur_n = first ? 0 : cnt[root];
          cur_r = first ? 0 : sr[root];
          cur_c = first ? 0 : sc[root];
        }
        ++cur_n;
        cur_r += r;
        cur_c += c;
      }
    if (cur >= 0) {
      cnt[cur] = cur_n;
      sr[cur] = cur_r;
      sc[cur] = cur_c;
    }
    std::vector<std::vector<int>> pieces(planes.size());
    for (const int i : roots)
      if (cnt[i] >= min_piece) pieces[lab[i]].push_back(i);
    for (std::size_t L = 0; L < planes.size(); ++L) {
      const auto& list = pieces[L];
      if (list.size() < 2 || list.size() > 64) continue;
      const auto& h = planes[L];
      for (std::size_t a = 0; a < list.size(); ++a)
        for (std::size_t b = a + 1; b < list.size(); ++b) {
          const int ra = list[a], rb = list[b];
          if (findRoot(parent, ra) == findRoot(parent, rb)) continue;
          const double r0 = static_cast<double>(sr[ra]) / cnt[ra],
                       c0 = static_cast<double>(sc[ra]) / cnt[ra],
                       r1 = static_cast<double>(sr[rb]) / cnt[rb],
                       c1 = static_cast<double>(sc[rb]) / cnt[rb];
          const int steps =
              static_cast<int>(std::ceil(std::max(std::fabs(r1 - r0), std::fabs(c1 - c0))));
          int behind = 0;
          for (int t = 0; t <= steps; ++t) {
            const double f = steps ? static_cast<double>(t) / steps : 0.0;
            const int r = static_cast<int>(std::lround(r0 + f * (r1 - r0)));
            const int c = static_cast<int>(std::lround(c0 + f * (c1 - c0)));
            const int i = r * C + c;
            const cv::Vec3f& p = point(i);
            if (!(p[2] > 0) || lab[i] == static_cast<int>(L)) continue;
            const double den =
                h.normal.x() * p[0] / p[2] + h.normal.y() * p[1] / p[2] + h.normal.z();
            const double z_plane = den < -1e-9 ? -h.d / den : 1e9;  // plane depth along this ray
            if (p[2] > z_plane + tol.at(z_plane)) ++behind;
          }
          if (behind <= std::max(1, steps / 20)) unite(parent, ra, rb);
        }
    }
  }
  const auto region_storage = std::make_unique_for_overwrite<int[]>(samples);
  int* const region_of = region_storage.get();  // every entry written below
  std::vector<RegionAccumulator> regions;
  {
    // The region of each root, written at the root: the first sample of its set in raster order.
    const auto root_region = std::make_unique_for_overwrite<int[]>(samples);
    std::vector<int> plane_region(planes.size(), -1);
    std::vector<std::array<int, 4>> bounds;  // c0, r0, c1, r1 of each region's samples
    // Consecutive samples mostly share a region: its count and column bounds stay in registers
    // until the region changes.
    int cur = -1, cur_samples = 0, cur_c0 = 0, cur_c1 = 0, cur_r1 = 0;
    auto flush = [&]() {
      if (cur < 0) return;
      regions[cur].samples = cur_samples;
      auto& b = bounds[cur];
      b[0] = cur_c0;
      b[2] = cur_c1;
      b[3] = cur_r1;
    };
    for (int r = 0, i = 0; r < R; ++r)
      for (int c = 0; c < C; ++c, ++i) {
        // parent[i] <= i (unite keeps the smaller root), so flattening in raster order leaves
        // every entry pointing at its root.
        const int root = parent[parent[i]];
        parent[i] = root;
        if (lab[i] < 0) {
          region_of[i] = -1;
          continue;
        }
        if (root == i) root_region[i] = -1;
        int& slot = params.split_connected_regions ? root_region[root] : plane_region[lab[i]];
        if (slot < 0) {
          slot = static_cast<int>(regions.size());
          regions.emplace_back();
          regions.back().plane = lab[i];
          bounds.push_back({c, r, c, r});
        }
        region_of[i] = slot;
        if (slot != cur) {
          flush();
          cur = slot;
          cur_samples = regions[slot].samples;
          const auto& b = bounds[slot];
          cur_c0 = b[0];
          cur_c1 = b[2];
        }
        ++cur_samples;
        cur_c0 = std::min(cur_c0, c);
        cur_c1 = std::max(cur_c1, c);
        cur_r1 = r;  // rows ascend
      }
    flush();
    for (std::size_t k = 0; k < regions.size(); ++k) {
      const auto& b = bounds[k];
      regions[k].sample_box = cv::Rect(b[0], b[1], b[2] - b[0] + 1, b[3] - b[1] + 1);
    }
  }
  // Pre-filter on sample counts (half the pixel threshold: edges add pixels at full resolution).
  // A region's samples lie in its sample box: the boxes of the small regions are searched, unless
  // together they cover more than the grid.
  const int min_samples = std::max(1, params.min_region_pixels / (2 * step * step));
  std::size_t small_area = 0;
  for (const auto& reg : regions)
    if (reg.samples < min_samples) small_area += static_cast<std::size_t>(reg.sample_box.area());
  if (small_area > samples) {
    for (std::size_t i = 0; i < samples; ++i)
      if (region_of[i] >= 0 && regions[region_of[i]].samples < min_samples) region_of[i] = -1;
  } else {
    for (std::size_t k = 0; k < regions.size(); ++k) {
      if (regions[k].samples >= min_samples) continue;
      const cv::Rect& b = regions[k].sample_box;
      for (int r = b.y; r < b.y + b.height; ++r) {
        int* row = region_of + static_cast<std::ptrdiff_t>(r) * C;
        for (int c = b.x; c < b.x + b.width; ++c)
          if (row[c] == static_cast<int>(k)) row[c] = -1;
      }
    }
  }
  // Pixels are labelled with region index + 1 in 16 bits. Past 65535 regions (small sample steps
  // on fragmented labels: a checkerboard of two planes makes every sample a region), the regions
  // kept above are renumbered in order and those still past the range are left unlabelled (their
  // samples leave the regions, as the small ones did).
  constexpr std::size_t kMaxRegions = 65535;
  if (regions.size() > kMaxRegions) {
    std::vector<int> new_index(regions.size(), -1);
    std::vector<RegionAccumulator> kept;
    for (std::size_t k = 0; k < regions.size() && kept.size() < kMaxRegions; ++k) {
      if (regions[k].samples < min_samples) continue;
      new_index[k] = static_cast<int>(kept.size());
      kept.push_back(regions[k]);
    }
    for (std::size_t i = 0; i < samples; ++i)
      if (region_of[i] >= 0) region_of[i] = new_index[region_of[i]];
    regions = std::move(kept);
  }

  // 3-4. Every pixel takes the closest candidate plane (the regions of its 3x3 sample
  //      neighbourhood) within the tolerance; see labelPixels.
  const std::size_t nreg = regions.size();
  std::vector<float> region_tol(nreg);
  for (std::size_t k = 0; k < nreg; ++k) region_tol[k] = tol_coef[regions[k].plane];
  const bool with_colour = !bgr.empty() && bgr.type() == CV_8UC3 && bgr.size() == depth_mm.size();
  PlaneDetection out;
  const LabelRuns label_runs =
      labelPixels(depth_mm, K, with_colour ? bgr : cv::Mat(), grid, region_of, planes, region_tol,
                  tol_floor, regions, out.labels);

  // 4b. One surface can come out as two adjacent regions of two nearly identical hypotheses (a
  //     strip fitted in pieces, a face found once by the Hough stage and once among the
  //     leftovers); the sample-level merge misses them when the sample fits of the pieces are
  //     poor. Merge depth-continuous neighbours whose full-resolution fits agree: joint RMS
  //     within max(merge_rms_factor x the worse RMS, tolerance / 3 at their range).
  std::vector<int> merged_into(nreg);
  std::iota(merged_into.begin(), merged_into.end(), 0);
  // Fits of the regions' full-resolution moments, computed once each (an eigen-solve costs more
  // than everything else a region pair needs).
  std::vector<PlaneFit> region_fit(nreg);
  std::vector<bool> has_fit(nreg, false);
  auto fitOf = [&](int k) -> const PlaneFit& {
    if (!has_fit[k]) {
      region_fit[k] = regions[k].moments.fit();
      has_fit[k] = true;
    }
    return region_fit[k];
  };
  bool any_merged = false;
  if (params.merge_coplanar_regions) {
    std::vector<std::pair<int, int>> adjacent;
    // Pairs with the right and the lower neighbour. Most samples have the same region on both
    // sides: the others (region borders) are flagged a row at a time in a branch-free pass that
    // vectorises, and the flags are scanned eight at a time.
    auto addPair = [&](int i, int j, int a) {
      const int b = region_of[j];
      if (b < 0 || b == a || !continuous(point(i)[2], point(j)[2])) return;
      adjacent.emplace_back(std::min(a, b), std::max(a, b));
    };
    std::vector<std::uint8_t> border(static_cast<std::size_t>(C) + 8, 0);  // whole words
    for (int r = 0; r < R; ++r) {
      const int* row = region_of + static_cast<std::ptrdiff_t>(r) * C;
      const int* below = r + 1 < R ? row + C : row;  // the last row has none
      for (int c = 0; c + 1 < C; ++c)
        border[c] = static_cast<std::uint8_t>(
            static_cast<int>(row[c] >= 0) &
            (static_cast<int>(row[c + 1] != row[c]) | static_cast<int>(below[c] != row[c])));
      border[C - 1] = static_cast<std::uint8_t>(static_cast<int>(row[C - 1] >= 0) &
                                                (below[C - 1] != row[C - 1]));
      forEachSetFlag(border.data(), C, [&](int c) {
        const int i = r * C + c;
        if (c + 1 < C) addPair(i, i + 1, row[c]);
        if (r + 1 < R) addPair(i, i + C, row[c]);
      });
    }
    std::sort(adjacent.begin(), adjacent.end());
    adjacent.erase(std::unique(adjacent.begin(), adjacent.end()), adjacent.end());
    const double cos_merge =
        std::cos(params.merge_coplanar_max_angle_deg * 3.14159265358979323846 / 180.0);
    for (const auto& [a0, b0] : adjacent) {
      const int a = findRoot(merged_into.data(), a0), b = findRoot(merged_into.data(), b0);
      if (a == b) continue;
      const PlaneFit &fa = fitOf(a), &fb = fitOf(b);
      if (!fa.valid || !fb.valid || fa.normal.dot(fb.normal) < cos_merge) continue;
      PlaneMoments joint = regions[a].moments;
      joint.merge(regions[b].moments);
      const PlaneFit f = joint.fit();
      const double z = std::max(fa.centroid.z(), fb.centroid.z());
      if (!f.valid ||
          f.rms_m > std::max(params.merge_coplanar_rms_factor * std::max(fa.rms_m, fb.rms_m),
                             tol.at(z) / 3.0))
        continue;
      auto& ra = regions[std::min(a, b)];
      auto& rb = regions[std::max(a, b)];
      ra.moments = joint;
      region_fit[std::min(a, b)] = f;
      ra.count += rb.count;
      ra.samples += rb.samples;
      ra.sample_box |= rb.sample_box;
      ra.u0 = std::min(ra.u0, rb.u0);
      ra.v0 = std::min(ra.v0, rb.v0);
      ra.u1 = std::max(ra.u1, rb.u1);
      ra.v1 = std::max(ra.v1, rb.v1);
      for (int ch = 0; ch < 3; ++ch) ra.colour[ch] += rb.colour[ch];
      rb.count = 0;  // dropped below; its pixels are renumbered to the merged region
      merged_into[std::max(a, b)] = std::min(a, b);
      any_merged = true;
    }
    if (any_merged)
      for (int i = 0; i < R * C; ++i)
        if (region_of[i] >= 0) region_of[i] = findRoot(merged_into.data(), region_of[i]);
  }

  // 5. Keep regions with enough pixels, number them 1.., refit, describe.
  auto keeps = [&](std::size_t k, std::size_t kept_so_far) {
    return regions[k].count >= static_cast<std::size_t>(std::max(1, params.min_region_pixels)) &&
           kept_so_far < 65535 && fitOf(static_cast<int>(k)).valid;
  };
  // The sample masks of the kept regions (1-cell margin), filled in one pass over the samples.
  std::vector<cv::Mat> masks(params.compute_polygons ? nreg : 0);
  if (params.compute_polygons) {
    // Offset from the mask's data of sample (0, 0), which may lie outside the mask (only the
    // samples of the box are written): kept as an integer, not as a pointer out of bounds.
    std::vector<std::uint8_t*> mask_data(nreg, nullptr);  // null: region not kept
    std::vector<std::ptrdiff_t> origin(nreg, 0);
    std::vector<std::ptrdiff_t> mask_step(nreg, 0);
    for (std::size_t k = 0, kept = 0; k < nreg; ++k) {
      if (!keeps(k, kept)) continue;
      ++kept;
      const cv::Rect sb = regions[k].sample_box;
      masks[k] = cv::Mat::zeros(sb.height + 2, sb.width + 2, CV_8UC1);
      mask_data[k] = masks[k].data;
      mask_step[k] = static_cast<std::ptrdiff_t>(masks[k].step[0]);
      origin[k] = (1 - sb.y) * mask_step[k] + (1 - sb.x);
    }
    // Consecutive samples mostly share a region: its mask and row offset are looked up when the
    // region changes.
    for (int r = 0, i = 0; r < R; ++r) {
      int cur = -1;
      std::uint8_t* data = nullptr;
      std::ptrdiff_t row_offset = 0;
      for (int c = 0; c < C; ++c, ++i) {
        const int k = region_of[i];
        if (k < 0) continue;
        if (k != cur) {
          cur = k;
          data = mask_data[k];
          row_offset = origin[k] + r * mask_step[k];
        }
        if (data) data[row_offset + c] = 255;
      }
    }
  }
  std::vector<std::uint16_t> lut(regions.size() + 1, 0);
  bool renumber = false;
  for (std::size_t k = 0; k < regions.size(); ++k) {
    auto& reg = regions[k];
    if (!keeps(k, out.planes.size())) {
      renumber = true;
      continue;
    }
    const PlaneFit& fit = fitOf(static_cast<int>(k));
    DetectedPlane p;
    p.id = static_cast<std::uint16_t>(out.planes.size() + 1);
    if (p.id != k + 1) renumber = true;
    lut[k + 1] = p.id;
    p.group = reg.plane;
    p.normal = fit.normal;
    p.d = fit.d;
    p.inliers = reg.count;
    p.rms_m = fit.rms_m;
    p.box = cv::Rect(reg.u0, reg.v0, reg.u1 - reg.u0 + 1, reg.v1 - reg.v0 + 1);
    if (with_colour) {
      const double n = std::max(1.0, reg.moments.count());
      p.mean_bgr = cv::Vec3b(cv::saturate_cast<uchar>(reg.colour[0] / n),
                             cv::saturate_cast<uchar>(reg.colour[1] / n),
                             cv::saturate_cast<uchar>(reg.colour[2] / n));
    }
    if (params.compute_polygons) {
      const cv::Rect sb = reg.sample_box;
      regionPolygon(masks[k], cv::Point(sb.x - 1, sb.y - 1), step, off, p.normal, p.d, K,
                    params.polygon_epsilon_cells, p.polygon, p.triangles);
    }
    out.planes.push_back(std::move(p));
  }
  for (std::size_t k = 0; k < nreg; ++k) {
    const int root = findRoot(merged_into.data(), static_cast<int>(k));
    if (root != static_cast<int>(k)) {
      lut[k + 1] = lut[root + 1];
      renumber = true;
    }
  }
  if (renumber) renumberLabels(out.labels, label_runs, lut);
  return out;
}

}  // namespace shapesense
