#include "segmentation/tiled_ransac.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "segmentation/edge_images.h"
#include "segmentation/region_growing.h"
#include "segmentation/working_image.h"
#include "shapesense/core/geometry/union_find.h"

namespace shapesense::segmentation {

namespace {

// A plane w = a u + b v + c in inverse depth (1/m) over working pixels (u, v).
struct TilePlane {
  bool ok = false;  ///< accepted (enough inliers)
  double a = 0, b = 0, c = 0;
  int inliers = 0;

  /// Whether inverse depth wv at (u, v) lies within t of the plane.
  bool fits(float u, float v, float wv, float t) const {
    return std::fabs(wv - static_cast<float>(a * u + b * v + c)) <= t;
  }
};

// The deterministic sampler: a linear congruential generator, so that results do not depend on
// the standard library.
struct Lcg {
  std::uint32_t s;
  std::uint32_t next() {
    s = s * 1664525u + 1013904223u;
    return s >> 8;
  }
};

// The tiles of the inverse-depth image and their planes.
struct TileGrid {
  const cv::Mat& inv;  ///< inverse depth, CV_32FC1, 0 = no depth
  int ts = 16;         ///< tile size (working pixels)
  int nx = 0, ny = 0;  ///< tiles per row, per column
  float thr = 0;       ///< inlier threshold (1/m)
  std::vector<TilePlane> planes;

  TileGrid(const cv::Mat& inverse_depth, int tile_size, float inlier_threshold)
      : inv(inverse_depth),
        ts(tile_size),
        nx((inverse_depth.cols + tile_size - 1) / tile_size),
        ny((inverse_depth.rows + tile_size - 1) / tile_size),
        thr(inlier_threshold),
        planes(static_cast<std::size_t>(nx) * ny) {}
  int count() const { return nx * ny; }
  cv::Rect rect(int tx, int ty) const {
    return cv::Rect(tx * ts, ty * ts, std::min(ts, inv.cols - tx * ts),
                    std::min(ts, inv.rows - ty * ts));
  }
  int tileAt(int u, int v) const { return (v / ts) * nx + u / ts; }
};

// Least-squares w = a u + b v + c over points (centred at (u0, v0) for conditioning).
bool fitPlaneLs(const std::vector<cv::Point3f>& pts, const std::vector<int>& idx, TilePlane& out) {
  if (idx.size() < 3) return false;
  double su = 0, sv = 0, sw = 0, suu = 0, suv = 0, svv = 0, suw = 0, svw = 0;
  const double n = static_cast<double>(idx.size());
  double mu = 0, mv = 0;
  for (int i : idx) {
    mu += pts[i].x;
    mv += pts[i].y;
  }
  mu /= n;
  mv /= n;
  for (int i : idx) {
    const double u = pts[i].x - mu, v = pts[i].y - mv, w = pts[i].z;
    su += u;
    sv += v;
    sw += w;
    suu += u * u;
    suv += u * v;
    svv += v * v;
    suw += u * w;
    svw += v * w;
  }
  const double det = suu * svv - suv * suv;
  if (std::fabs(det) < 1e-9) return false;
  const double a = (suw * svv - svw * suv) / det;
  const double b = (svw * suu - suw * suv) / det;
  const double c = (sw - a * su - b * sv) / n;
  out.a = a;
  out.b = b;
  out.c = c - a * mu - b * mv;
  return true;
}

// Inliers among every `stride`-th point of pts within thr of the plane (float arithmetic).
int countInliers(const std::vector<cv::Point3f>& pts, const TilePlane& h, float thr, int stride,
                 std::vector<int>* inliers = nullptr) {
  const float ha = static_cast<float>(h.a), hb = static_cast<float>(h.b),
              hc = static_cast<float>(h.c);
  int cnt = 0;
  const int n = static_cast<int>(pts.size());
  for (int i = 0; i < n; i += stride) {
    const bool in = std::fabs(pts[i].z - (ha * pts[i].x + hb * pts[i].y + hc)) <= thr;
    cnt += in;
    if (in && inliers) inliers->push_back(i);
  }
  return cnt;
}

// The best of p.iterations planes through three sampled points, by inliers among every other
// point; ok = false when no sample gave one.
TilePlane bestSampledPlane(const std::vector<cv::Point3f>& pts, float thr,
                           const TiledRansacParams& p, Lcg& rng) {
  const int n = static_cast<int>(pts.size());
  int best = 0;
  TilePlane best_plane;
  for (int it = 0; it < p.iterations; ++it) {
    const auto& a = pts[rng.next() % n];
    const auto& b = pts[rng.next() % n];
    const auto& c = pts[rng.next() % n];
    // Solve w = A u + B v + C through three points.
    const double u1 = b.x - a.x, v1 = b.y - a.y, w1 = b.z - a.z;
    const double u2 = c.x - a.x, v2 = c.y - a.y, w2 = c.z - a.z;
    const double det = u1 * v2 - u2 * v1;
    if (std::fabs(det) < 4.0) continue;  // nearly collinear samples
    TilePlane h;
    h.a = (w1 * v2 - w2 * v1) / det;
    h.b = (u1 * w2 - u2 * w1) / det;
    h.c = a.z - h.a * a.x - h.b * a.y;
    const int cnt = countInliers(pts, h, thr, 2);
    if (cnt > best) {
      best = cnt;
      best_plane = h;
    }
  }
  best_plane.ok = best > 0;
  return best_plane;
}

// Step 1: a RANSAC plane per tile, refined on its inliers and recounted on all pixels.
void fitTilePlanes(TileGrid& g, const TiledRansacParams& p) {
  std::vector<cv::Point3f> pts;
  std::vector<int> inl;
  pts.reserve(g.ts * g.ts);
  for (int ty = 0; ty < g.ny; ++ty) {
    for (int tx = 0; tx < g.nx; ++tx) {
      const cv::Rect rc = g.rect(tx, ty);
      pts.clear();
      for (int v = rc.y; v < rc.y + rc.height; ++v) {
        const float* row = g.inv.ptr<float>(v);
        for (int u = rc.x; u < rc.x + rc.width; ++u) {
          if (row[u] > 0) pts.emplace_back(static_cast<float>(u), static_cast<float>(v), row[u]);
        }
      }
      const int n = static_cast<int>(pts.size());
      if (n < std::max(12, rc.area() / 3)) continue;
      Lcg rng{p.seed * 2654435761u + static_cast<std::uint32_t>(ty * g.nx + tx) * 40503u + 1u};
      TilePlane plane = bestSampledPlane(pts, g.thr, p, rng);
      if (!plane.ok) continue;
      for (int round = 0; round < 2; ++round) {
        inl.clear();
        countInliers(pts, plane, g.thr, 1, &inl);
        if (round == 0 && !fitPlaneLs(pts, inl, plane)) break;
      }
      TilePlane& tp = g.planes[ty * g.nx + tx];
      tp = plane;
      tp.inliers = static_cast<int>(inl.size());
      tp.ok = tp.inliers >= p.min_inlier_fraction * n;
    }
  }
}

// Fraction of tile ib's inliers explained by tile ia's plane (sampled every other pixel).
double crossFit(const TileGrid& g, int ia, int ib) {
  const TilePlane& A = g.planes[ia];
  const TilePlane& B = g.planes[ib];
  const cv::Rect rc = g.rect(ib % g.nx, ib / g.nx);
  int both = 0, total = 0;
  for (int v = rc.y; v < rc.y + rc.height; v += 2) {
    const float* row = g.inv.ptr<float>(v);
    for (int u = rc.x; u < rc.x + rc.width; u += 2) {
      if (row[u] <= 0) continue;
      const float fu = static_cast<float>(u), fv = static_cast<float>(v);
      if (!B.fits(fu, fv, row[u], g.thr)) continue;
      ++total;
      both += A.fits(fu, fv, row[u], 1.5f * g.thr);
    }
  }
  return total > 0 ? static_cast<double>(both) / total : 0.0;
}

// Step 2: sets of neighbouring tiles whose planes explain each other's inliers.
std::vector<int> mergeTiles(const TileGrid& g, double merge_fraction) {
  std::vector<int> parent(g.count());
  resetSets(parent);
  for (int ty = 0; ty < g.ny; ++ty) {
    for (int tx = 0; tx < g.nx; ++tx) {
      const int i = ty * g.nx + tx;
      if (!g.planes[i].ok) continue;
      for (int j : {tx + 1 < g.nx ? i + 1 : -1, ty + 1 < g.ny ? i + g.nx : -1}) {
        if (j < 0 || !g.planes[j].ok) continue;
        if (crossFit(g, i, j) >= merge_fraction && crossFit(g, j, i) >= merge_fraction) {
          // Under j's root (not unite's smaller root): the region ids follow from it.
          parent[findRoot(parent, i)] = findRoot(parent, j);
        }
      }
    }
  }
  return parent;
}

// Step 3: seeds are each accepted tile's inliers; a pixel joins a neighbour's region when it
// fits the plane of its own tile (if that tile belongs to the region) or else the plane the
// neighbour was grown with. This crosses tile borders, so tiles leave no seams, and follows
// gently curved surfaces whose tile planes were chained by the merge. Region id = root + 1.
cv::Mat growTilePlanes(const TileGrid& g, std::vector<int>& parent) {
  const int rows = g.inv.rows, cols = g.inv.cols;
  cv::Mat labels(rows, cols, CV_32SC1, cv::Scalar(0));
  std::vector<int> plane_of(static_cast<std::size_t>(rows) * cols, -1);
  std::vector<int> queue;
  queue.reserve(static_cast<std::size_t>(rows) * cols);
  for (int v = 0; v < rows; ++v) {
    const float* row = g.inv.ptr<float>(v);
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < cols; ++u) {
      const int t = g.tileAt(u, v);
      if (row[u] <= 0 || !g.planes[t].ok) continue;
      if (!g.planes[t].fits(static_cast<float>(u), static_cast<float>(v), row[u], g.thr)) continue;
      l[u] = findRoot(parent, t) + 1;
      plane_of[v * cols + u] = t;
      queue.push_back(v * cols + u);
    }
  }
  int* L = labels.ptr<int>(0);
  const float* W = g.inv.ptr<float>(0);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int idx = queue[head];
    const int u = idx % cols, v = idx / cols;
    const int label = L[idx];
    const int pl = plane_of[idx];
    const int nbr[4] = {u > 0 ? idx - 1 : -1, u + 1 < cols ? idx + 1 : -1, v > 0 ? idx - cols : -1,
                        v + 1 < rows ? idx + cols : -1};
    for (int q : nbr) {
      if (q < 0 || L[q] != 0 || W[q] <= 0) continue;
      const int qu = q % cols, qv = q / cols;
      const int tq = g.tileAt(qu, qv);
      int use = pl;
      if (g.planes[tq].ok && findRoot(parent, tq) + 1 == label) use = tq;
      if (!g.planes[use].fits(static_cast<float>(qu), static_cast<float>(qv), W[q], g.thr))
        continue;
      L[q] = label;
      plane_of[q] = use;
      queue.push_back(q);
    }
  }
  return labels;
}

// Step 4: components of unlabelled depth-continuous pixels (edges <= max_edge) of at least
// min_px become regions first_label + component. Returns the number of components.
int labelLeftovers(const cv::Mat& edges, int max_edge, int min_px, int first_label,
                   cv::Mat& labels) {
  const int rows = labels.rows, cols = labels.cols;
  cv::Mat left_mask(rows, cols, CV_8UC1);
  for (int v = 0; v < rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const auto* e = edges.ptr<std::uint8_t>(v);
    auto* m = left_mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < cols; ++u) m[u] = (l[u] == 0 && e[u] <= max_edge) ? 255 : 0;
  }
  cv::Mat comp;
  const int nc = cv::connectedComponents(left_mask, comp, 4, CV_32S);
  std::vector<int> csize(nc, 0);
  for (int v = 0; v < rows; ++v) {
    const int* c = comp.ptr<int>(v);
    for (int u = 0; u < cols; ++u) ++csize[c[u]];
  }
  for (int v = 0; v < rows; ++v) {
    const int* c = comp.ptr<int>(v);
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < cols; ++u) {
      if (c[u] > 0 && csize[c[u]] >= min_px) l[u] = first_label + c[u];
    }
  }
  return nc;
}

}  // namespace

cv::Mat segmentTiledRansac(const cv::Mat& depth, const CameraIntrinsics& intr,
                           const TiledRansacParams& p) {
  const RegionParams& rp = p.region;
  const WorkingImage w = makeWorkingImage(depth, intr, rp);
  const cv::Mat inv = inverseDepth(w.depth);
  TileGrid grid(inv, std::max(4, p.tile_size),
                static_cast<float>(p.inlier_noise_steps * inverseDepthStep(rp.noise)));
  fitTilePlanes(grid, p);
  std::vector<int> parent = mergeTiles(grid, p.merge_fraction);
  cv::Mat labels = growTilePlanes(grid, parent);
  // The non-planar rest: grouped by depth steps, then flooded over the depth-step relief.
  const cv::Mat edges = depthStepEdges(w, p.leftovers, rp.noise);
  const int min_marker = std::max(1, rp.min_marker_px / (w.ds * w.ds));
  const int nt = grid.count();
  const int nc = labelLeftovers(edges, rp.marker_max_edge, min_marker, nt, labels);
  flood(edges, labels);
  return finishRegions(labels, nt + nc, edges, w, depth, rp);
}

}  // namespace shapesense::segmentation
