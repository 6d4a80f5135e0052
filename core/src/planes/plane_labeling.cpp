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
#include <span>

#include "shapesense/core/planes/plane_polygon.h"

#include "planes/crease_strips.h"
#include "planes/curved_regions.h"
#include "planes/pixel_labeling.h"
#include "planes/plane_growth.h"
#include "planes/plane_regions.h"
#include "planes/planes_kernels.h"
#include "shapesense/core/geometry/union_find.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {
namespace {

using labeling::LabelRuns;
using labeling::RegionAccumulator;

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

}  // namespace

std::vector<double> planeNoiseSteps(const PlaneSampleGrid& grid, const cv::Mat& sample_labels,
                                    const std::vector<PlaneHypothesis>& planes,
                                    const PlaneTolerance& tolerance) {
  const std::size_t planes_count = planes.size();
  const double step1 = tolerance.noise.depthStep(1.0);  // depthStep(z) = step1 z^2
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
  std::vector<double> steps(planes_count, -1.0);
  for (std::size_t L = 0; L < planes_count; ++L)
    if (count[L] >= 6) steps[L] = std::sqrt(sum[L] / count[L]);
  return steps;
}

std::vector<float> planeToleranceCoefficients(const std::vector<double>& noise_steps,
                                              const PlaneLabelingParams& params) {
  const PlaneTolerance& tol = params.tolerance;
  const double step1 = tol.noise.depthStep(1.0);
  std::vector<float> coef(noise_steps.size(), static_cast<float>(tol.noise_steps * step1));
  if (!(params.adaptive_tolerance_factor > 0.0)) return coef;
  const double lo = std::min(params.min_tolerance_steps, tol.noise_steps);
  for (std::size_t L = 0; L < noise_steps.size(); ++L) {
    if (noise_steps[L] < 0.0) continue;  // too few samples to tell: keep the full tolerance
    const double steps =
        std::clamp(params.adaptive_tolerance_factor * noise_steps[L], lo, tol.noise_steps);
    coef[L] = static_cast<float>(steps * step1);
  }
  return coef;
}

std::vector<float> planeToleranceCoefficients(const PlaneSampleGrid& grid,
                                              const cv::Mat& sample_labels,
                                              const std::vector<PlaneHypothesis>& planes,
                                              const PlaneLabelingParams& params) {
  if (!(params.adaptive_tolerance_factor > 0.0))
    return planeToleranceCoefficients(std::vector<double>(planes.size(), -1.0), params);
  return planeToleranceCoefficients(planeNoiseSteps(grid, sample_labels, planes, params.tolerance),
                                    params);
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
  const double cos_gate = std::cos(degToRad(params.grow_max_normal_deg));
  const double cos_unreliable = std::cos(degToRad(params.grow_max_unreliable_normal_deg));
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

namespace {

// Fits of the regions' full-resolution moments, each computed once, when first needed (an
// eigen-solve costs more than everything else a region pair needs).
class RegionFits {
 public:
  explicit RegionFits(const std::vector<RegionAccumulator>& regions)
      : regions_(regions), fit_(regions.size()), has_(regions.size(), false) {}
  const PlaneFit& of(int k) {
    if (!has_[k]) {
      fit_[k] = regions_[k].moments.fit();
      has_[k] = true;
    }
    return fit_[k];
  }
  void set(int k, const PlaneFit& fit) {
    fit_[k] = fit;
    has_[k] = true;
  }

 private:
  const std::vector<RegionAccumulator>& regions_;
  std::vector<PlaneFit> fit_;
  std::vector<bool> has_;
};

// One surface can come out as two adjacent regions of two nearly identical hypotheses (a strip
// fitted in pieces, a face found once by the Hough stage and once among the leftovers); the
// sample-level merge misses them when the sample fits of the pieces are poor. Merges
// depth-continuous neighbours whose full-resolution fits agree: joint RMS within
// max(merge_rms_factor x the worse RMS, tolerance / 3 at their range). Returns the union-find of
// the merges over the regions (a merged region points at the one it joined, which holds the
// union's sums; its own count is 0); region_of is updated.
std::vector<int> mergeCoplanarRegions(const PlaneSampleGrid& grid,
                                      const SampleContinuity& continuous,
                                      const PlaneLabelingParams& params, int* region_of,
                                      std::vector<RegionAccumulator>& regions, RegionFits& fits) {
  const int R = grid.points.rows, C = grid.points.cols;
  auto point = [&](int i) -> const cv::Vec3f& { return grid.points.ptr<cv::Vec3f>(0)[i]; };
  const PlaneTolerance& tol = params.tolerance;
  std::vector<int> merged_into(regions.size());
  std::iota(merged_into.begin(), merged_into.end(), 0);
  bool any_merged = false;
  {
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
    const double cos_merge = std::cos(degToRad(params.merge_coplanar_max_angle_deg));
    for (const auto& [a0, b0] : adjacent) {
      const int a = findRoot(merged_into, a0), b = findRoot(merged_into, b0);
      if (a == b) continue;
      const PlaneFit &fa = fits.of(a), &fb = fits.of(b);
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
      fits.set(std::min(a, b), f);
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
        if (region_of[i] >= 0) region_of[i] = findRoot(merged_into, region_of[i]);
  }

  return merged_into;
}

// Whether region k is kept (after kept_so_far others): enough pixels, a valid fit, and a 16-bit
// label left.
bool keepsRegion(std::vector<RegionAccumulator>& regions, RegionFits& fits, std::size_t k,
                 std::size_t kept_so_far, int min_region_pixels) {
  return !regions[k].curved &&
         regions[k].count >= static_cast<std::size_t>(std::max(1, min_region_pixels)) &&
         kept_so_far < 65535 && fits.of(static_cast<int>(k)).valid;
}

// The sample masks of the kept regions (1-cell margin around their sample box; empty for the
// others), filled in one pass over the samples.
std::vector<cv::Mat> keptRegionMasks(const PlaneSampleGrid& grid, const int* region_of,
                                     std::vector<RegionAccumulator>& regions, RegionFits& fits,
                                     int min_region_pixels) {
  auto keeps = [&](std::size_t k, std::size_t kept_so_far) {
    return keepsRegion(regions, fits, k, kept_so_far, min_region_pixels);
  };
  const int R = grid.points.rows, C = grid.points.cols;
  const std::size_t nreg = regions.size();
  std::vector<cv::Mat> masks(nreg);
  {
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
  return masks;
}

// Marks the regions that would be reported but lie on a curved surface (labeling::curvedRegions),
// so that keepsRegion drops them; `labels` holds region k as k + 1.
void dropCurvedRegions(const PlaneSampleGrid& grid, const PlaneLabelingParams& params,
                       const cv::Mat& labels, RegionFits& fits, const std::vector<int>& root,
                       std::vector<RegionAccumulator>& regions) {
  const std::size_t nreg = regions.size();
  std::vector<bool> candidate(nreg, false);
  std::vector<Eigen::Vector3d> normals(nreg, Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < nreg; ++k) {
    if (root[k] != static_cast<int>(k) ||
        !keepsRegion(regions, fits, k, 0, params.min_region_pixels))
      continue;
    candidate[k] = true;
    normals[k] = fits.of(static_cast<int>(k)).normal;
  }
  const std::vector<bool> curved =
      labeling::curvedRegions(grid, labels, root, candidate, normals, params);
  for (std::size_t k = 0; k < curved.size(); ++k) regions[k].curved = curved[k];
}

// The fits of the regions that lost pixels (`lost`, per region) taken again.
void refitRegionsThatLostPixels(const std::vector<std::uint8_t>& lost,
                                const std::vector<RegionAccumulator>& regions, RegionFits& fits) {
  for (std::size_t k = 0; k < lost.size(); ++k)
    if (lost[k]) fits.set(static_cast<int>(k), regions[k].moments.fit());
}

// The kept regions as planes numbered 1.. in region order (their refit, pixel box, mean colour
// and polygon), and the labels renumbered to them (merged regions take their survivor's id,
// dropped ones 0). Returns the renumbering: region k's plane id at k + 1 (0: dropped).
std::vector<std::uint16_t> describeRegions(const CameraIntrinsics& K, const PlaneSampleGrid& grid,
                                           bool with_colour, const PlaneLabelingParams& params,
                                           const int* region_of,
                                           std::vector<RegionAccumulator>& regions,
                                           RegionFits& fits, const std::vector<int>& root_of,
                                           const LabelRuns& label_runs, PlaneDetection& out) {
  const int step = grid.step, off = grid.offset;
  const std::size_t nreg = regions.size();
  std::vector<cv::Mat> masks;
  if (params.compute_polygons)
    masks = keptRegionMasks(grid, region_of, regions, fits, params.min_region_pixels);
  std::vector<std::uint16_t> lut(regions.size() + 1, 0);
  bool renumber = false;
  for (std::size_t k = 0; k < regions.size(); ++k) {
    auto& reg = regions[k];
    if (!keepsRegion(regions, fits, k, out.planes.size(), params.min_region_pixels)) {
      renumber = true;
      continue;
    }
    const PlaneFit& fit = fits.of(static_cast<int>(k));
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
    const int root = root_of[k];
    if (root != static_cast<int>(k)) {
      lut[k + 1] = lut[root + 1];
      renumber = true;
    }
  }
  if (renumber) labeling::renumberLabels(out.labels, label_runs, lut);
  return lut;
}

}  // namespace

PlaneDetection labelPlanes(const cv::Mat& depth_mm, const CameraIntrinsics& K, const cv::Mat& bgr,
                           const PlaneSampleGrid& grid, cv::Mat& sample_labels,
                           const std::vector<PlaneHypothesis>& planes,
                           const PlaneLabelingParams& params) {
  CV_Assert(depth_mm.type() == CV_16UC1 && sample_labels.type() == CV_32SC1 &&
            sample_labels.size() == grid.points.size());
  const int R = grid.points.rows, C = grid.points.cols;
  if (R == 0 || C == 0) {  // a frame narrower than the sample offset holds no sample
    PlaneDetection none;
    none.labels = cv::Mat::zeros(depth_mm.size(), CV_16UC1);
    return none;
  }
  const PlaneTolerance& tol = params.tolerance;
  const float tol_floor = static_cast<float>(tol.floor_m);
  const SampleContinuity continuous(grid, params);
  int* lab = sample_labels.ptr<int>(0);

  const std::vector<double> noise_steps = planeNoiseSteps(grid, sample_labels, planes, tol);
  const std::vector<float> tol_coef = planeToleranceCoefficients(noise_steps, params);
  growSampleLabels(grid, sample_labels, planes, params, tol_coef);
  // 2. Connected regions (same plane, 4-connected, depth-continuous), and pieces of one plane
  //    separated only by things in front of it joined; then the small ones dropped.
  // The per-sample arrays are not zeroed where every entry read is written first (zeroing them
  // cost as much as some of the passes over them).
  const std::size_t samples = static_cast<std::size_t>(R) * C;
  const auto parent_storage = std::make_unique_for_overwrite<int[]>(samples);
  const std::span<int> parent(parent_storage.get(), samples);
  resetSets(parent);
  if (params.split_connected_regions) {
    labeling::connectSamples(grid, lab, continuous, parent);
    if (params.merge_occluded_pieces)
      labeling::mergeOccludedPieces(grid, lab, planes, params, parent);
  }
  const auto region_storage = std::make_unique_for_overwrite<int[]>(samples);
  int* const region_of = region_storage.get();  // every entry written by buildRegions
  std::vector<RegionAccumulator> regions;
  labeling::buildRegions(grid, lab, parent, params.split_connected_regions, planes.size(),
                         region_of, regions);
  labeling::dropSmallRegions(grid, params.min_region_pixels, region_of, regions);
  // 3-4. Every pixel takes the closest candidate plane (the regions of its 3x3 sample
  //      neighbourhood) within the tolerance; see labelPixels.
  const std::size_t nreg = regions.size();
  std::vector<float> region_tol(nreg);
  for (std::size_t k = 0; k < nreg; ++k) region_tol[k] = tol_coef[regions[k].plane];
  const bool with_colour = !bgr.empty() && bgr.type() == CV_8UC3 && bgr.size() == depth_mm.size();
  PlaneDetection out;
  const LabelRuns label_runs =
      labeling::labelPixels(depth_mm, K, with_colour ? bgr : cv::Mat(), grid, region_of, planes,
                            region_tol, tol_floor, regions, out.labels);

  // 4b. One surface can come out as two adjacent regions of two nearly identical hypotheses (a
  //     strip fitted in pieces, a face found once by the Hough stage and once among the
  //     leftovers); the sample-level merge misses them when the sample fits of the pieces are
  //     poor. Merge depth-continuous neighbours whose full-resolution fits agree: joint RMS
  //     within max(merge_rms_factor x the worse RMS, tolerance / 3 at their range).
  RegionFits fits(regions);
  std::vector<int> merged_into(nreg);
  std::iota(merged_into.begin(), merged_into.end(), 0);
  if (params.merge_coplanar_regions)
    merged_into = mergeCoplanarRegions(grid, continuous, params, region_of, regions, fits);
  // Each region's survivor of the merges (itself when not merged), which holds its sums.
  std::vector<int> root(nreg);
  for (std::size_t k = 0; k < nreg; ++k) root[k] = findRoot(merged_into, static_cast<int>(k));
  // 5. Strips taken across creases go back (crease_strips.h).
  cv::Mat peeled_pixels;
  refitRegionsThatLostPixels(
      labeling::peelCreaseStrips(depth_mm, K, with_colour ? bgr : cv::Mat(), grid, region_of,
                                 params, noise_steps, root, regions, out.labels, peeled_pixels),
      regions, fits);
  // 5b. Regions that bend are not planes. After the peeling: a strip of the surface beyond a
  //     crease bends a flat face's quadric as a curved surface would.
  dropCurvedRegions(grid, params, out.labels, fits, root, regions);
  // 5c. The smaller face of a region on two faces goes back too (crease_strips.h). After the
  //     curvature check, which a curved surface cut down to one face would pass.
  refitRegionsThatLostPixels(
      labeling::giveBackSmallerFaces(depth_mm, K, with_colour ? bgr : cv::Mat(), params, root,
                                     regions, out.labels, peeled_pixels),
      regions, fits);
  // 6. Keep regions with enough pixels, number them 1.., refit, describe.
  const std::vector<std::uint16_t> plane_of_region = describeRegions(
      K, grid, with_colour, params, region_of, regions, fits, root, label_runs, out);
  // 7. The parts of the planes' surfaces that no sample reached (plane_growth.h), each with its
  //    plane's own tolerance.
  if (params.grow_into_unreached_pixels) {
    std::vector<float> tolerance_of_plane(out.planes.size() + 1, 0.0f);
    for (std::size_t k = 0; k < nreg; ++k)
      if (plane_of_region[k + 1] && root[k] == static_cast<int>(k))
        tolerance_of_plane[plane_of_region[k + 1]] = region_tol[k];
    const DepthStepRule continuity{.noise_steps = tol.noise_steps, .noise = tol.noise};
    labeling::growPlanesIntoUnlabelled(depth_mm, K, tolerance_of_plane, tol_floor, continuity,
                                       peeled_pixels, out);
  }
  return out;
}

}  // namespace shapesense
