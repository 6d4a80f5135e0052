// The full-resolution pixel labelling step of labelPlanes (see pixel_labeling.h).
#include "planes/pixel_labeling.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "planes/planes_kernels.h"

namespace shapesense::labeling {

PinholePlane pinholePlane(const Eigen::Vector3d& normal, double d, const CameraIntrinsics& K) {
  return {static_cast<float>(normal.x() / K.fx), static_cast<float>(normal.y() / K.fy),
          static_cast<float>(normal.z() - normal.x() * K.cx / K.fx - normal.y() * K.cy / K.fy),
          static_cast<float>(d)};
}
namespace {

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

// The regions' planes in the pinhole form (pinholePlane), a, b, c, d per region.
std::vector<float> pixelPlaneCoefficients(const std::vector<RegionAccumulator>& regions,
                                          const std::vector<PlaneHypothesis>& planes,
                                          const CameraIntrinsics& K) {
  std::vector<float> coef(4 * regions.size());
  for (std::size_t k = 0; k < regions.size(); ++k) {
    const auto& h = planes[regions[k].plane];
    const PinholePlane p = pinholePlane(h.normal, h.d, K);
    coef[4 * k + 0] = p.a;
    coef[4 * k + 1] = p.b;
    coef[4 * k + 2] = p.c;
    coef[4 * k + 3] = p.d;
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
// is none); counts[k]: pixels labelled with candidate k (the runs' spans need them). The runs of
// a row of `cols` pixels go left to right (the kernels may store back pixels past a run's end).
void labelRun(const std::uint16_t* drow, std::uint16_t* lrow, int cols, const PixelRun& run,
              const std::vector<float>& coef, float fv, const std::vector<float>& region_tol,
              float tol_floor, std::array<int, 4>& counts) {
  counts.fill(0);
  if (run.list[1] < 0) {
    counts[0] = planes_kernels::labelSingleCandidateRun(
        drow, lrow, cols, run.u0, run.u1, pixelPlane(coef, region_tol, run.list[0], fv), tol_floor,
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
  planes_kernels::labelCandidatesRun(drow, lrow, cols, run.u0, run.u1, candidates, labels, k,
                                     tol_floor, counts.data());
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

// The first pixel column >= u0 on the moment lattice.
inline int firstMomentPixel(int u0) {
  return (u0 + kMomentStride - 1) / kMomentStride * kMomentStride;
}

// The six sums of a run's moments in the row's own terms (see addRunMoments): MomentSums needs
// ten, because it cannot use that y / z is constant along an image row.
struct RowMomentSums {
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
  void add(const RowMomentSums& o) {
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
  RowMomentSums even, odd;
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

}  // namespace

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
      labelRun(drow, lrow, depth_mm.cols, run, coef, fv, region_tol, tol_floor, counts);
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

}  // namespace shapesense::labeling
