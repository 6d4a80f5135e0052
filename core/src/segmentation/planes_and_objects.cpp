#include "segmentation/planes_and_objects.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "segmentation/object_shapes.h"
#include "segmentation/segmentation_kernels.h"
#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/geometry/union_find.h"

namespace shapesense::segmentation {
namespace {

RowRuns labelRunsOf(const cv::Mat& labels) {
  RowRuns runs(static_cast<std::size_t>(labels.rows));
  for (int v = 0; v < labels.rows; ++v)
    labelRuns(labels.ptr<int>(v), labels.cols, runs[static_cast<std::size_t>(v)]);
  return runs;
}

// The runs of the rows whose labels changed (changed[v] != 0), taken again.
void retakeRuns(const cv::Mat& labels, const std::vector<std::uint8_t>& changed, RowRuns& runs) {
  for (int v = 0; v < labels.rows; ++v)
    if (changed[static_cast<std::size_t>(v)])
      labelRuns(labels.ptr<int>(v), labels.cols, runs[static_cast<std::size_t>(v)]);
}

// Pixels of each label (index = label, up to the largest), run by run: a per-pixel increment of
// one counter stalls on its own store wherever neighbours share a label, which is almost
// everywhere.
std::vector<int> labelCounts(const RowRuns& runs) {
  std::vector<int> counts(1, 0);
  for (const auto& row : runs)
    for (const LabelRun& run : row) {
      const auto label = static_cast<std::size_t>(run.label);
      if (label >= counts.size()) counts.resize(label + 1, 0);
      counts[label] += run.end - run.begin;
    }
  return counts;
}

// Plane ids stay as they are; object region o becomes plane_count + o. CV_32SC1, 0 = none.
cv::Mat overlayObjects(const cv::Mat& depth_mm, const cv::Mat& plane_labels, int plane_count,
                       const cv::Mat& object_labels) {
  cv::Mat out(depth_mm.size(), CV_32SC1);
  for (int v = 0; v < out.rows; ++v)
    overlayObjectsRow(depth_mm.ptr<std::uint16_t>(v), plane_labels.ptr<std::uint16_t>(v),
                      object_labels.ptr<std::uint16_t>(v), plane_count, out.cols, out.ptr<int>(v));
  return out;
}

// Each 4-connected piece of an object region (labels above plane_count) becomes a region of
// its own. A plane_prediction region minus the planes' pixels can fall apart: the bands it
// kept along a plane's borders (where the plane detector left a crease strip to the surface
// beyond) lie around every object on that plane, and as one region they would join those
// objects to each other.
// `runs` are the label image's runs; their labels change with the image's (the runs stay
// maximal: two runs side by side hold different labels before, and so after).
void splitDisconnectedObjects(cv::Mat& labels, int plane_count, RowRuns& runs) {
  // Object runs numbered in raster order; first[v]: the number of row v's first run.
  std::vector<int> first(runs.size() + 1, 0);
  for (std::size_t v = 0; v < runs.size(); ++v)
    first[v + 1] = first[v] + static_cast<int>(runs[v].size());
  std::vector<int> parent(static_cast<std::size_t>(first.back()));
  resetSets(parent);
  for (std::size_t v = 1; v < runs.size(); ++v) {
    const auto& above = runs[v - 1];
    const auto& row = runs[v];
    std::size_t a = 0;
    for (std::size_t r = 0; r < row.size(); ++r) {
      if (row[r].label <= plane_count) continue;
      while (a < above.size() && above[a].end <= row[r].begin) ++a;
      for (std::size_t k = a; k < above.size() && above[k].begin < row[r].end; ++k)
        if (above[k].label == row[r].label)
          unite(parent, first[v - 1] + static_cast<int>(k), first[v] + static_cast<int>(r));
    }
  }
  // New object labels from plane_count + 1, one per piece, in raster order of its first run.
  std::vector<int> piece_label(parent.size(), 0);
  int next = plane_count + 1;
  for (std::size_t v = 0; v < runs.size(); ++v) {
    int* l = labels.ptr<int>(static_cast<int>(v));
    for (std::size_t r = 0; r < runs[v].size(); ++r) {
      LabelRun& run = runs[v][r];
      if (run.label <= plane_count) continue;
      const int root = findRoot(parent, first[v] + static_cast<int>(r));
      if (piece_label[static_cast<std::size_t>(root)] == 0)
        piece_label[static_cast<std::size_t>(root)] = next++;
      run.label = piece_label[static_cast<std::size_t>(root)];
      std::fill(l + run.begin, l + run.end, run.label);
    }
  }
}

// Object regions (labels above plane_count) that are small, or thin everywhere (no pixel with
// its whole (2 r + 1)^2 window in the region), are cleared: the slivers plane_prediction leaves
// along creases and borders between planes, which the growth below hands to their neighbours.
// `runs`: the label image's runs.
void clearSlivers(cv::Mat& labels, int plane_count, RowRuns& runs,
                  const PlanesAndObjectsParams& p) {
  // Pixels whose 3x3 window holds one label, eroded to the (2 r + 1)^2 window.
  cv::Mat uniform = cv::Mat::zeros(labels.size(), CV_8UC1);
  for (int v = 1; v + 1 < labels.rows; ++v)
    uniformLabelRow(labels.ptr<int>(v - 1), labels.ptr<int>(v), labels.ptr<int>(v + 1), labels.cols,
                    uniform.ptr<std::uint8_t>(v));
  if (p.sliver_radius_px > 1) {
    const int k = 2 * (p.sliver_radius_px - 1) + 1;
    cv::erode(uniform, uniform, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
  }
  // The runs of every row give the sizes, the interior flags and the clearing.
  const std::vector<int> size = labelCounts(runs);
  const std::size_t count = size.size();
  std::vector<std::uint8_t> has_interior(count, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const auto* in = uniform.ptr<std::uint8_t>(v);
    for (const LabelRun& run : runs[static_cast<std::size_t>(v)])
      if (!has_interior[run.label])
        has_interior[run.label] = std::find(in + run.begin, in + run.end, 255) != in + run.end;
  }
  std::vector<std::uint8_t> cleared(count, 0);
  for (std::size_t label = static_cast<std::size_t>(plane_count) + 1; label < count; ++label)
    cleared[label] = size[label] < p.min_object_px || !has_interior[label];
  for (int v = 0; v < labels.rows; ++v) {
    int* l = labels.ptr<int>(v);
    for (LabelRun& run : runs[static_cast<std::size_t>(v)])
      if (cleared[run.label]) {
        std::fill(l + run.begin, l + run.end, 0);
        run.label = 0;
      }
  }
}

// Pixels with depth and no region, by index (row-major).
std::vector<int> unlabelledPixels(const cv::Mat& depth_mm, const RowRuns& runs) {
  std::vector<int> pixels;
  for (int v = 0; v < depth_mm.rows; ++v) {
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    for (const LabelRun& run : runs[static_cast<std::size_t>(v)])
      if (!run.label)
        for (int u = run.begin; u < run.end; ++u)
          if (depth[u]) pixels.push_back(v * depth_mm.cols + u);
  }
  return pixels;
}

// Growth passes: in each, every pixel still without a region takes the label of its
// 4-neighbour nearest in depth among those labelled before the pass and on its surface (no
// depth step between them), so a pass adds one ring.
// `runs`: the label image's runs; they change with it.
void growIntoUnlabelled(const cv::Mat& depth_mm, const PlanesAndObjectsParams& p, cv::Mat& labels,
                        RowRuns& runs) {
  CV_Assert(labels.isContinuous() && depth_mm.isContinuous());
  std::vector<int> open = unlabelledPixels(depth_mm, runs), still_open;
  const int rows = labels.rows, cols = labels.cols;
  int* const lab = labels.ptr<int>(0);
  const std::uint16_t* const depth = depth_mm.ptr<std::uint16_t>(0);
  std::vector<std::pair<int, int>> taken;
  std::vector<std::uint8_t> changed(static_cast<std::size_t>(rows), 0);
  for (int pass = 0; pass < p.grow_passes && !open.empty(); ++pass) {
    taken.clear();
    still_open.clear();
    for (const int i : open) {
      const int v = i / cols, u = i % cols;
      const double z = depth[i] * 1e-3;
      double best = 0.0;
      int label = 0;
      const auto consider = [&](int j) {
        if (!lab[j] || !depth[j]) return;
        const double zn = depth[j] * 1e-3;
        if (p.continuity.isStep(z, zn)) return;
        const double dz = std::abs(zn - z);
        if (!label || dz < best) {
          best = dz;
          label = lab[j];
        }
      };
      if (u > 0) consider(i - 1);
      if (u + 1 < cols) consider(i + 1);
      if (v > 0) consider(i - cols);
      if (v + 1 < rows) consider(i + cols);
      if (label)
        taken.emplace_back(i, label);
      else
        still_open.push_back(i);
    }
    if (taken.empty()) break;
    for (const auto& [i, label] : taken) {
      lab[i] = label;
      changed[static_cast<std::size_t>(i / cols)] = 1;
    }
    open.swap(still_open);
  }
  retakeRuns(labels, changed, runs);
}

// Pixel pairs across the border of two regions: on one surface (no depth step between them)
// or not.
struct Border {
  int continuous = 0;
  int steps = 0;
};

// Two labels as one key, first << 32 | second, and back.
std::uint64_t labelPairKey(int first, int second) {
  return static_cast<std::uint64_t>(first) << 32 | static_cast<std::uint32_t>(second);
}

std::pair<int, int> labelPair(std::uint64_t key) {
  return {static_cast<int>(key >> 32), static_cast<int>(key & 0xffffffffu)};
}

// The borders of every two 4-adjacent regions, keyed by their labels, the smaller first.
using Borders = std::unordered_map<std::uint64_t, Border>;

std::uint64_t borderKey(int a, int b) { return labelPairKey(std::min(a, b), std::max(a, b)); }

// Runs of two regions side by side, and overlapping runs of two regions in rows one above the
// other, are where the borders lie: walking the runs skips the insides of regions.
Borders regionBorders(const cv::Mat& depth_mm, const RowRuns& runs,
                      const DepthStepRule& continuity) {
  Borders borders;
  // Neighbouring pixels of a border mostly lie between the same two regions: the last entry
  // saves most lookups (the map's entries stay where they are as it grows).
  std::uint64_t last_key = 0;
  Border* last = nullptr;
  const auto count = [&](int la, int lb, std::uint16_t za, std::uint16_t zb) {
    if (!za || !zb) return;
    const std::uint64_t key = borderKey(la, lb);
    if (!last || key != last_key) {
      last = &borders[key];
      last_key = key;
    }
    ++(continuity.isStep(za * 1e-3, zb * 1e-3) ? last->steps : last->continuous);
  };
  for (std::size_t v = 0; v < runs.size(); ++v) {
    const auto* z = depth_mm.ptr<std::uint16_t>(static_cast<int>(v));
    const auto& row = runs[v];
    for (std::size_t r = 0; r + 1 < row.size(); ++r)
      if (row[r].label && row[r + 1].label)
        count(row[r].label, row[r + 1].label, z[row[r].end - 1], z[row[r + 1].begin]);
    if (v + 1 == runs.size()) continue;
    const auto* z_below = depth_mm.ptr<std::uint16_t>(static_cast<int>(v) + 1);
    const auto& below = runs[v + 1];
    std::size_t b = 0;
    for (const LabelRun& run : row) {
      if (!run.label) continue;
      while (b < below.size() && below[b].end <= run.begin) ++b;
      for (std::size_t k = b; k < below.size() && below[k].begin < run.end; ++k) {
        if (!below[k].label || below[k].label == run.label) continue;
        const int end = std::min(run.end, below[k].end);
        for (int u = std::max(run.begin, below[k].begin); u < end; ++u)
          count(run.label, below[k].label, z[u], z_below[u]);
      }
    }
  }
  return borders;
}

// Every region takes the label of its set's root, its smallest label: a tin and its top take
// the top's. The runs take it too (two runs side by side may then hold one label).
void relabelToRoots(std::vector<int>& parent, RowRuns& runs, cv::Mat& labels) {
  for (std::size_t v = 0; v < runs.size(); ++v) {
    int* l = labels.ptr<int>(static_cast<int>(v));
    for (LabelRun& run : runs[v]) {
      const int root = findRoot(parent, run.label);
      if (root == run.label) continue;
      run.label = root;
      std::fill(l + run.begin, l + run.end, root);
    }
  }
}

// What the joining steps know of the regions after the growth: each object region's shape,
// each border, and the sets joined so far (parent, over labels).
struct RegionGraph {
  int plane_count = 0;
  ObjectShapes shapes;
  Borders borders;
  std::vector<int> parent;
};

// Faces the plane detector found only in part: an object region that is not curved, borders a
// plane on one surface and lies on that plane's surface (the RMS distance of its points to it
// is within face_part_rms_steps sensor depth steps at its range, seen along the plane's
// normal) joins it; of several such planes, the one it lies closest to.
void joinFacesFoundInPart(const PlaneDetection& planes, const PlanesAndObjectsParams& p,
                          RegionGraph& graph) {
  std::vector<const DetectedPlane*> plane_of(static_cast<std::size_t>(graph.plane_count) + 1,
                                             nullptr);
  for (const DetectedPlane& plane : planes.planes) plane_of[plane.id] = &plane;
  std::vector<std::pair<double, int>> nearest(graph.parent.size(), {0.0, 0});  // (RMS, plane)
  for (const auto& [key, border] : graph.borders) {
    const auto [plane, object] = labelPair(key);
    if (plane > graph.plane_count || object <= graph.plane_count || !plane_of[plane] ||
        graph.shapes.curved[object] || border.continuous < p.join_min_border_px)
      continue;
    const PlaneMoments& points = graph.shapes.moments[object];
    if (points.count() < 12) continue;
    const double rms =
        std::sqrt(points.meanSquaredDistance(plane_of[plane]->normal, plane_of[plane]->d));
    // The sensor's depth step seen along the plane's normal: a grazing plane's points scatter
    // off it by a fraction of their scatter in depth.
    const Eigen::Vector3d centroid = points.centroid();
    const double along_normal = std::abs(plane_of[plane]->normal.dot(centroid)) / centroid.z();
    const double tolerance =
        p.face_part_rms_steps * p.continuity.noise.depthStep(centroid.z()) * along_normal;
    auto& [nearest_rms, nearest_plane] = nearest[static_cast<std::size_t>(object)];
    if (rms <= tolerance && (!nearest_plane || rms < nearest_rms)) {
      nearest_rms = rms;
      nearest_plane = plane;
    }
  }
  for (std::size_t object = 0; object < nearest.size(); ++object)
    if (nearest[object].second)
      unite(graph.parent, static_cast<int>(object), nearest[object].second);
}

// Curved objects made whole again: plane_prediction cuts a bowl at its rim and a ball or a
// bin where it bends fastest, and a tin's flat top is a region of its own. Two curved object
// regions that meet on one surface (no depth step along most of their border) and that one
// quadric fits are joined; then a region that is not curved and not yet joined to anything
// joins the curved object along which most of its border on one surface lies.
void joinCurvedObjects(const PlanesAndObjectsParams& p, RegionGraph& graph) {
  const std::vector<bool>& curved = graph.shapes.curved;
  std::vector<int>& parent = graph.parent;
  const auto on_one_surface = [&](const Border& b) {
    return b.continuous >= p.join_min_border_px &&
           b.continuous >= p.join_min_continuous_share * (b.continuous + b.steps);
  };
  for (const auto& [key, border] : graph.borders) {
    const auto [a, b] = labelPair(key);
    if (curved[a] && curved[b] && on_one_surface(border) &&
        oneQuadricFitsBoth(graph.shapes, a, b, p))
      unite(parent, a, b);
  }
  // Each region's continuous border, in total and with each curved set it touches.
  std::vector<int> continuous_border(parent.size(), 0);
  std::unordered_map<std::uint64_t, int> border_with_curved;  // (region, curved root)
  for (const auto& [key, border] : graph.borders) {
    const auto [a, b] = labelPair(key);
    continuous_border[a] += border.continuous;
    continuous_border[b] += border.continuous;
    const int root_a = findRoot(parent, a), root_b = findRoot(parent, b);
    if (root_a == root_b) continue;
    if (!curved[a] && curved[b]) border_with_curved[labelPairKey(a, root_b)] += border.continuous;
    if (!curved[b] && curved[a]) border_with_curved[labelPairKey(b, root_a)] += border.continuous;
  }
  std::vector<std::pair<int, int>> caps;  // (region, curved root)
  for (const auto& [key, continuous] : border_with_curved) {
    const auto [region, object] = labelPair(key);
    if (findRoot(parent, region) == region && p.cap_min_border_share > 0.0 &&
        continuous >= p.join_min_border_px &&
        continuous >= p.cap_min_border_share * continuous_border[region])
      caps.emplace_back(region, object);
  }
  for (const auto& [region, object] : caps) unite(parent, region, object);
}

// Object regions that are two faces meeting at a crease (a table leg's two sides, which the
// plane detector missed and plane_prediction did not cut), split into their faces: the pixels
// nearer the second face's plane take a new label. Regions joined to another are left whole.
void splitCreasedObjects(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                         RegionGraph& graph, cv::Mat& labels, RowRuns& runs) {
  const std::size_t count = graph.parent.size();
  std::vector<int> members(count, 0);
  for (std::size_t label = 1; label < count; ++label)
    ++members[static_cast<std::size_t>(findRoot(graph.parent, static_cast<int>(label)))];
  const std::vector<std::optional<TwoPlanes>>& faces = graph.shapes.faces;
  std::vector<int> second_label(count, 0);
  int next_label = static_cast<int>(count);
  for (std::size_t label = static_cast<std::size_t>(graph.plane_count) + 1; label < count; ++label)
    if (members[label] == 1 && faces[label]) second_label[label] = next_label++;
  if (next_label == static_cast<int>(count)) return;
  std::vector<std::uint8_t> changed(runs.size(), 0);
  for (std::size_t v = 0; v < runs.size(); ++v) {
    int* l = labels.ptr<int>(static_cast<int>(v));
    const auto* z = depth_mm.ptr<std::uint16_t>(static_cast<int>(v));
    for (const LabelRun& run : runs[v]) {
      const auto label = static_cast<std::size_t>(run.label);
      if (!second_label[label]) continue;
      changed[v] = 1;
      const TwoPlanes& two = *faces[label];
      for (int u = run.begin; u < run.end; ++u) {
        if (!z[u]) continue;
        const Eigen::Vector3d x = intrinsics.backproject(u, static_cast<double>(v), z[u] * 1e-3);
        if (two.nearerB(x)) l[u] = second_label[label];
      }
    }
  }
  retakeRuns(labels, changed, runs);
}

// Regions that are pieces of one surface, joined; then regions that are two faces, split.
// `runs`: the label image's runs; their labels change with the image's.
void joinPieces(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                const PlaneDetection& planes, int plane_count, const PlanesAndObjectsParams& p,
                cv::Mat& labels, RowRuns& runs) {
  if (!p.join_face_parts && !p.join_curved_objects && !p.split_creased_objects) return;
  int label_count = 0;
  for (const auto& row : runs)
    for (const LabelRun& run : row) label_count = std::max(label_count, run.label);
  if (label_count <= plane_count) return;
  RegionGraph graph;
  graph.plane_count = plane_count;
  graph.shapes = objectShapes(depth_mm, intrinsics, runs, plane_count, label_count, p);
  graph.borders = regionBorders(depth_mm, runs, p.continuity);
  graph.parent.resize(static_cast<std::size_t>(label_count) + 1);
  resetSets(graph.parent);
  if (p.join_face_parts) joinFacesFoundInPart(planes, p, graph);
  if (p.join_curved_objects) joinCurvedObjects(p, graph);
  relabelToRoots(graph.parent, runs, labels);
  if (p.split_creased_objects) splitCreasedObjects(depth_mm, intrinsics, graph, labels, runs);
}

// Regions of at least min_pixels, renumbered 1..N in raster order of their first pixel.
// `runs`: the label image's runs.
cv::Mat compactRegions(const cv::Mat& labels, const RowRuns& runs, int min_pixels) {
  const std::vector<int> size = labelCounts(runs);
  std::vector<int> id(size.size(), 0);
  int next = 0;
  cv::Mat out(labels.size(), CV_16UC1);
  for (int v = 0; v < labels.rows; ++v) {
    auto* o = out.ptr<std::uint16_t>(v);
    for (const LabelRun& run : runs[static_cast<std::size_t>(v)]) {
      const int label = run.label;
      if (label && size[label] >= min_pixels && !id[label] && next < 65535) id[label] = ++next;
      std::fill(o + run.begin, o + run.end, static_cast<std::uint16_t>(label ? id[label] : 0));
    }
  }
  return out;
}

}  // namespace

cv::Mat segmentPlanesAndObjects(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                const PlaneDetection& planes, const SegmentationParams& params) {
  CV_Assert(depth_mm.type() == CV_16UC1 && planes.labels.type() == CV_16UC1 &&
            planes.labels.size() == depth_mm.size());
  const PlanesAndObjectsParams& p = params.planes_and_objects;
  const cv::Mat objects =
      segmentDepth(depth_mm, intrinsics, SegmentationMethod::kPlanePrediction, params);
  int plane_count = 0;
  for (const auto& plane : planes.planes) plane_count = std::max<int>(plane_count, plane.id);
  cv::Mat labels = overlayObjects(depth_mm, planes.labels, plane_count, objects);
  RowRuns runs = labelRunsOf(labels);
  splitDisconnectedObjects(labels, plane_count, runs);
  clearSlivers(labels, plane_count, runs, p);
  growIntoUnlabelled(depth_mm, p, labels, runs);
  joinPieces(depth_mm, intrinsics, planes, plane_count, p, labels, runs);
  return compactRegions(labels, runs, p.min_region_px);
}

}  // namespace shapesense::segmentation
