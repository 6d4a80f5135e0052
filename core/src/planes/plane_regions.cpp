// The connected regions of labelPlanes (see plane_regions.h).
#include "planes/plane_regions.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "shapesense/core/geometry/union_find.h"

namespace shapesense::labeling {

void connectSamples(const PlaneSampleGrid& grid, const int* lab, const SampleContinuity& continuous,
                    std::span<int> parent) {
  const int R = grid.points.rows, C = grid.points.cols;
  const std::size_t samples = static_cast<std::size_t>(R) * C;
  auto point = [&](int i) -> const cv::Vec3f& { return grid.points.ptr<cv::Vec3f>(0)[i]; };
  {
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
}

void mergeOccludedPieces(const PlaneSampleGrid& grid, const int* lab,
                         const std::vector<PlaneHypothesis>& planes,
                         const PlaneLabelingParams& params, std::span<int> parent) {
  const int R = grid.points.rows, C = grid.points.cols;
  const std::size_t samples = static_cast<std::size_t>(R) * C;
  auto point = [&](int i) -> const cv::Vec3f& { return grid.points.ptr<cv::Vec3f>(0)[i]; };
  const int step = grid.step;
  const PlaneTolerance& tol = params.tolerance;
  {
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
}

void buildRegions(const PlaneSampleGrid& grid, const int* lab, std::span<int> parent, bool split,
                  std::size_t planes, int* region_of, std::vector<RegionAccumulator>& regions) {
  const int R = grid.points.rows, C = grid.points.cols;
  const std::size_t samples = static_cast<std::size_t>(R) * C;
  {
    // The region of each root, written at the root: the first sample of its set in raster order.
    const auto root_region = std::make_unique_for_overwrite<int[]>(samples);
    std::vector<int> plane_region(planes, -1);
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
        int& slot = split ? root_region[root] : plane_region[lab[i]];
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
}

void dropSmallRegions(const PlaneSampleGrid& grid, int min_region_pixels, int* region_of,
                      std::vector<RegionAccumulator>& regions) {
  const int R = grid.points.rows, C = grid.points.cols, step = grid.step;
  const std::size_t samples = static_cast<std::size_t>(R) * C;
  // Pre-filter on sample counts (half the pixel threshold: edges add pixels at full resolution).
  // A region's samples lie in its sample box: the boxes of the small regions are searched, unless
  // together they cover more than the grid.
  const int min_samples = std::max(1, min_region_pixels / (2 * step * step));
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
}

}  // namespace shapesense::labeling
