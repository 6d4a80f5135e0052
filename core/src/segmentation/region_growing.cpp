#include "segmentation/region_growing.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "segmentation/coplanar_merge.h"
#include "segmentation/segmentation_kernels.h"

namespace shapesense::segmentation {

namespace {

// Components of the pixels with edge <= max_edge whose size passes `keep`, numbered from
// first_label + 1 into `markers` (only where keep says so). Returns the last label used.
template <class Keep>
int markComponents(const cv::Mat& edges, int max_edge, const cv::Mat& markers_before,
                   int first_label, Keep keep, cv::Mat& markers) {
  cv::Mat labels;
  const int n = cv::connectedComponents(edges <= std::min(max_edge, 254), labels, 4, CV_32S);
  std::vector<int> size(n, 0);
  std::vector<char> has_marker(n, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const int* m = markers_before.empty() ? nullptr : markers_before.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u) {
      ++size[l[u]];
      if (m) has_marker[l[u]] |= m[u] > 0;
    }
  }
  std::vector<int> remap(n, 0);
  int next = first_label;
  for (int i = 1; i < n; ++i) remap[i] = keep(size[i], has_marker[i] != 0) ? ++next : 0;
  if (markers.empty()) markers.create(labels.size(), CV_32SC1);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    int* m = markers.ptr<int>(v);
    if (markers_before.empty()) {
      for (int u = 0; u < labels.cols; ++u) m[u] = remap[l[u]];
    } else {
      for (int u = 0; u < labels.cols; ++u)
        if (remap[l[u]]) m[u] = remap[l[u]];
    }
  }
  return next;
}

}  // namespace

int markersFromEdges(const cv::Mat& edges, int max_edge, int min_px, cv::Mat& markers,
                     const cv::Mat& fallback) {
  markers.release();
  const int next = markComponents(
      edges, max_edge, {}, 0, [&](int size, bool) { return size >= min_px; }, markers);
  if (fallback.empty()) return next;
  return markComponents(
      fallback, max_edge, markers, next,
      [&](int size, bool has_marker) { return !has_marker && size >= min_px; }, markers);
}

// Pixels are taken in order of their edge strength, and first-in first-out among equal
// strengths, so on a plateau of equal strength the basins advance at the same speed and meet in
// the middle.
//
// Why not cv::watershed: it orders pixels by the colour difference between a pixel and its
// labelled neighbour, not by height. Along the crest of an edge band that difference is ~0, so
// the first basin to reach a crest runs along it and takes the whole network of bands around
// every object (seen on mosd_tabletop: one region made of the rims of all objects plus strips
// of the table, leaving the table at 75% coverage). A bucket queue over the 256 levels is also
// O(N) and faster than cv::watershed plus the relief it needs.
void flood(const cv::Mat& edges, cv::Mat& markers) {
  const int rows = markers.rows, cols = markers.cols;
  CV_Assert(markers.isContinuous() && edges.isContinuous());
  int* L = markers.ptr<int>(0);
  const std::uint8_t* E = edges.ptr<std::uint8_t>(0);
  const int n = rows * cols;
  std::array<std::vector<int>, 256> bucket;
  // Seeds, in raster order: marker pixels with an unlabelled 4-neighbour (interior marker pixels
  // cannot spread).
  collectFloodSeeds(L, E, rows, cols, bucket);
  for (int level = 0; level < 256; ++level) {
    std::vector<int>& q = bucket[level];
    for (std::size_t head = 0; head < q.size(); ++head) {  // q grows while it is read (FIFO)
      const int i = q[head];
      const int label = L[i];
      const int u = i % cols;
      const int nb[4] = {u > 0 ? i - 1 : -1, u + 1 < cols ? i + 1 : -1, i - cols, i + cols};
      for (int j : nb) {
        if (j < 0 || j >= n || L[j] > 0) continue;
        L[j] = label;
        bucket[std::max<int>(level, E[j])].push_back(j);
      }
    }
    std::vector<int>().swap(q);
  }
}

namespace {

// Working-resolution labels (CV_32SC1, ids up to max_label) renumbered 1..K in raster order of
// first appearance, so that the full-resolution passes below run on uint16. K is at most the
// number of pixels / min marker size, far below 65535 for any sane parameters; ids past 65535
// become 0 (unassigned) rather than wrapping.
cv::Mat denseLabels(const cv::Mat& labels, int max_label, int& count) {
  std::vector<std::uint16_t> remap(static_cast<std::size_t>(std::max(max_label, 0)) + 1, 0);
  std::vector<char> assigned(remap.size(), 0);
  int next = 0;
  cv::Mat out(labels.size(), CV_16UC1);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const int x = std::max(l[u], 0);
      if (x > 0 && !assigned[x]) {
        assigned[x] = 1;
        remap[x] = next < 65535 ? static_cast<std::uint16_t>(++next) : 0;
      }
      o[u] = remap[x];
    }
  }
  count = std::min(next, 65535);
  return out;
}

// A full-resolution pixel (column u of row `depth`) whose depth does not match its block's
// takes the label of the neighbouring block (of working row vc) with the closest depth.
void relabelFromClosestBlock(const cv::Mat& labels, const WorkingImage& w,
                             const std::uint16_t* depth, int vc, int u, std::uint16_t* out) {
  const int uc = std::min(u >> 1, labels.cols - 1);
  int best = 1 << 30;
  for (int dv = -1; dv <= 1; ++dv) {
    const int vv = vc + dv;
    if (vv < 0 || vv >= labels.rows) continue;
    const auto* lr = labels.ptr<std::uint16_t>(vv);
    const auto* dr = w.depth.ptr<std::uint16_t>(vv);
    for (int du = -1; du <= 1; ++du) {
      const int uu = uc + du;
      if (uu < 0 || uu >= labels.cols || dr[uu] == 0 || lr[uu] == 0) continue;
      const int diff = std::abs(static_cast<int>(depth[u]) - static_cast<int>(dr[uu]));
      if (diff < best) {
        best = diff;
        out[u] = lr[uu];
      }
    }
  }
}

// Upsamples working-resolution labels (dense uint16, see denseLabels) to the full image. A
// full-resolution pixel whose depth does not match its block's depth (a block on a step took the
// foreground) takes the label of the neighbouring block with the closest depth. Pixels without
// depth get 0. CV_16UC1.
cv::Mat upsample(const cv::Mat& labels, const WorkingImage& w, const cv::Mat& depth,
                 const KinectNoiseModel& noise) {
  cv::Mat out(depth.size(), CV_16UC1);
  if (w.ds == 1) {  // makeWorkingImage clamps ds to 1 or 2
    for (int v = 0; v < depth.rows; ++v) {
      const auto* d = depth.ptr<std::uint16_t>(v);
      const auto* l = labels.ptr<std::uint16_t>(v);
      auto* o = out.ptr<std::uint16_t>(v);
      for (int u = 0; u < depth.cols; ++u) o[u] = d[u] == 0 ? 0 : l[u];
    }
    return out;
  }
  // Per working row, the block label, depth and depth tolerance are expanded to full width once,
  // so the per-pixel pass is branch-free uint16 arithmetic that vectorises; the few pixels that
  // do not match their block (next to steps) are fixed afterwards.
  const float k =
      static_cast<float>(3.0 * noise.disparity_step_px / noise.focal_baseline_px_m * 1e-3);
  const int cols = depth.cols;
  std::vector<std::uint16_t> lab2(cols), dep2(cols), tol2(cols);
  std::vector<std::uint8_t> bad(cols);
  for (int v = 0; v < depth.rows; ++v) {
    const auto* d = depth.ptr<std::uint16_t>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    const int vc = std::min(v / 2, labels.rows - 1);
    if (v % 2 == 0) {
      expandBlockRow(labels.ptr<std::uint16_t>(vc), w.depth.ptr<std::uint16_t>(vc), labels.cols,
                     cols, k, lab2.data(), dep2.data(), tol2.data());
    }
    if (!labelFullRow(d, lab2.data(), dep2.data(), tol2.data(), cols, o, bad.data())) continue;
    for (int u = 0; u < cols; ++u) {
      if (std::uint64_t eight; u + 8 <= cols && (std::memcpy(&eight, &bad[u], 8), eight == 0)) {
        u += 7;  // none of the eight
        continue;
      }
      if (bad[u]) relabelFromClosestBlock(labels, w, d, vc, u, o);
    }
  }
  return out;
}

// The end of the run of equal labels that starts at u in a row of `cols` labels.
int runEnd(const std::uint16_t* l, int u, int cols) {
  const std::uint16_t x = l[u];
  int end = u + 1;
  // Four labels per compare while the run lasts (runs are long: regions are large).
  const std::uint64_t four = x * 0x0001000100010001ull;
  for (std::uint64_t chunk; end + 4 <= cols; end += 4) {
    std::memcpy(&chunk, l + end, sizeof chunk);
    if (chunk != four) break;
  }
  while (end < cols && l[end] == x) ++end;
  return end;
}

// Drops regions below min_px and renumbers the rest 1..N in raster order of first appearance,
// in place (CV_16UC1 with labels <= max_label).
void compact(cv::Mat& labels, int max_label, int min_px) {
  // By runs of equal labels: consecutive pixels mostly share a label, and a per-pixel
  // ++size[label] is a serial memory dependency that costs more than the upsampling.
  std::vector<int> size(static_cast<std::size_t>(max_label) + 1, 0);
  std::vector<std::uint16_t> order;  // labels in raster order of first appearance
  for (int v = 0; v < labels.rows; ++v) {
    const auto* l = labels.ptr<std::uint16_t>(v);
    int u = 0;
    while (u < labels.cols) {
      const std::uint16_t x = l[u];
      const int end = runEnd(l, u, labels.cols);
      if (x != 0 && size[x] == 0) order.push_back(x);
      size[x] += end - u;
      u = end;
    }
  }
  std::vector<std::uint16_t> remap(static_cast<std::size_t>(max_label) + 1, 0);
  int next = 0;
  bool identity = true;
  for (std::uint16_t x : order) {
    if (size[x] >= min_px) remap[x] = static_cast<std::uint16_t>(++next);
    identity = identity && remap[x] == x;
  }
  if (identity && static_cast<int>(order.size()) == max_label) return;
  for (int v = 0; v < labels.rows; ++v) {
    auto* l = labels.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols;) {
      const int end = runEnd(l, u, labels.cols);
      std::fill(l + u, l + end, remap[l[u]]);
      u = end;
    }
  }
}

}  // namespace

cv::Mat finishRegions(cv::Mat& markers, int max_label, const cv::Mat& edges, const WorkingImage& w,
                      const cv::Mat& depth, const RegionParams& rp) {
  mergeCoplanarRegions(markers, max_label, edges, w, rp);
  int count = 0;
  cv::Mat full = upsample(denseLabels(markers, max_label, count), w, depth, rp.noise);
  compact(full, count, rp.min_region_px);
  return full;
}

}  // namespace shapesense::segmentation
