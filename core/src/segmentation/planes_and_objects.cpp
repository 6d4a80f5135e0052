#include "segmentation/planes_and_objects.h"

#include <algorithm>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace shapesense::segmentation {
namespace {

// Plane ids stay as they are; object region o becomes plane_count + o. CV_32SC1, 0 = none.
cv::Mat overlayObjects(const cv::Mat& depth_mm, const cv::Mat& plane_labels, int plane_count,
                       const cv::Mat& object_labels) {
  cv::Mat out(depth_mm.size(), CV_32SC1);
  for (int v = 0; v < out.rows; ++v) {
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    const auto* plane = plane_labels.ptr<std::uint16_t>(v);
    const auto* object = object_labels.ptr<std::uint16_t>(v);
    auto* o = out.ptr<int>(v);
    for (int u = 0; u < out.cols; ++u)
      o[u] = plane[u] ? plane[u] : (depth[u] && object[u] ? plane_count + object[u] : 0);
  }
  return out;
}

// Object regions (labels above plane_count) that are small, or thin everywhere (no pixel with
// its whole (2 r + 1)^2 window in the region), are cleared: the slivers plane_prediction leaves
// along creases and borders between planes, which the growth below hands to their neighbours.
void clearSlivers(cv::Mat& labels, int plane_count, const PlanesAndObjectsParams& p) {
  double max_label = 0;
  cv::minMaxLoc(labels, nullptr, &max_label);
  const std::size_t count = static_cast<std::size_t>(max_label) + 1;
  // A pixel is interior when the smallest and largest label of its window are its own.
  cv::Mat as_float, lowest, highest;
  labels.convertTo(as_float, CV_32F);  // exact: labels stay far below 2^24
  const int r = std::max(0, p.sliver_radius_px);
  const cv::Mat window = cv::getStructuringElement(cv::MORPH_RECT, {2 * r + 1, 2 * r + 1});
  cv::erode(as_float, lowest, window, {-1, -1}, 1, cv::BORDER_REPLICATE);
  cv::dilate(as_float, highest, window, {-1, -1}, 1, cv::BORDER_REPLICATE);
  std::vector<int> size(count, 0), interior(count, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const float* lo = lowest.ptr<float>(v);
    const float* hi = highest.ptr<float>(v);
    for (int u = 0; u < labels.cols; ++u) {
      ++size[l[u]];
      interior[l[u]] += lo[u] == hi[u];
    }
  }
  for (int v = 0; v < labels.rows; ++v) {
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] > plane_count && (size[l[u]] < p.min_object_px || interior[l[u]] == 0)) l[u] = 0;
  }
}

// One pass: each unlabelled pixel with depth takes the label of the 4-neighbour nearest in
// depth among those on its surface (no depth step between them). False when none changed.
bool growOnePass(const cv::Mat& depth_mm, const DepthStepRule& step, cv::Mat& labels) {
  const cv::Mat before = labels.clone();
  bool changed = false;
  const int rows = labels.rows, cols = labels.cols;
  for (int v = 0; v < rows; ++v) {
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    const int* in = before.ptr<int>(v);
    int* out = labels.ptr<int>(v);
    for (int u = 0; u < cols; ++u) {
      if (in[u] || !depth[u]) continue;
      const double z = depth[u] * 1e-3;
      double best = 0.0;
      int label = 0;
      const auto consider = [&](int label_n, std::uint16_t depth_n) {
        if (!label_n || !depth_n) return;
        const double zn = depth_n * 1e-3;
        if (step.isStep(z, zn)) return;
        const double dz = std::abs(zn - z);
        if (!label || dz < best) {
          best = dz;
          label = label_n;
        }
      };
      if (u > 0) consider(in[u - 1], depth[u - 1]);
      if (u + 1 < cols) consider(in[u + 1], depth[u + 1]);
      if (v > 0) consider(before.ptr<int>(v - 1)[u], depth_mm.ptr<std::uint16_t>(v - 1)[u]);
      if (v + 1 < rows) consider(before.ptr<int>(v + 1)[u], depth_mm.ptr<std::uint16_t>(v + 1)[u]);
      if (label) {
        out[u] = label;
        changed = true;
      }
    }
  }
  return changed;
}

// Regions of at least min_pixels, renumbered 1..N in raster order of their first pixel.
cv::Mat compactRegions(const cv::Mat& labels, int min_pixels) {
  double max_label = 0;
  cv::minMaxLoc(labels, nullptr, &max_label);
  std::vector<int> size(static_cast<std::size_t>(max_label) + 1, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u) ++size[l[u]];
  }
  std::vector<int> id(size.size(), 0);
  int next = 0;
  cv::Mat out(labels.size(), CV_16UC1);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const int label = l[u];
      if (label && size[label] >= min_pixels && !id[label] && next < 65535) id[label] = ++next;
      o[u] = static_cast<std::uint16_t>(label ? id[label] : 0);
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
  clearSlivers(labels, plane_count, p);
  for (int pass = 0; pass < p.grow_passes && growOnePass(depth_mm, p.continuity, labels); ++pass) {
  }
  return compactRegions(labels, p.min_region_px);
}

}  // namespace shapesense::segmentation
