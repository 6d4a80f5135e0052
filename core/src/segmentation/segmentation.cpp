#include "shapesense/core/segmentation/segmentation.h"

#include <algorithm>

#include "segmentation/edge_images.h"
#include "segmentation/planes_and_objects.h"
#include "segmentation/region_growing.h"
#include "segmentation/tiled_ransac.h"
#include "segmentation/working_image.h"

namespace shapesense {

std::string_view formatSegmentationMethod(SegmentationMethod method) {
  switch (method) {
    case SegmentationMethod::kDepthStep:
      return "depth_step";
    case SegmentationMethod::kNormalEdges:
      return "normal_edges";
    case SegmentationMethod::kFused:
      return "fused";
    case SegmentationMethod::kPlanePrediction:
      return "plane_prediction";
    case SegmentationMethod::kTiledRansac:
      return "tiled_ransac";
    case SegmentationMethod::kPlanesAndObjects:
      return "planes_objects";
  }
  return "unknown";
}

std::optional<SegmentationMethod> parseSegmentationMethod(std::string_view name) {
  for (auto m : kSegmentationMethods) {
    if (formatSegmentationMethod(m) == name) return m;
  }
  return std::nullopt;
}

std::vector<std::string> segmentationMethodNames() {
  std::vector<std::string> names;
  for (auto m : kSegmentationMethods) names.emplace_back(formatSegmentationMethod(m));
  return names;
}

std::string listSegmentationMethods(std::string_view last_separator) {
  std::string list;
  for (std::size_t i = 0; i < kSegmentationMethods.size(); ++i) {
    if (i > 0) list += i + 1 == kSegmentationMethods.size() ? last_separator : ", ";
    list += formatSegmentationMethod(kSegmentationMethods[i]);
  }
  return list;
}

namespace {

const RegionParams& regionParams(SegmentationMethod method, const SegmentationParams& p) {
  switch (method) {
    case SegmentationMethod::kDepthStep:
      return p.depth_step.region;
    case SegmentationMethod::kNormalEdges:
      return p.normal_edges.region;
    case SegmentationMethod::kFused:
      return p.fused.region;
    case SegmentationMethod::kPlanePrediction:
    case SegmentationMethod::kPlanesAndObjects:
      return p.plane_prediction.region;
    case SegmentationMethod::kTiledRansac:
      return p.tiled_ransac.region;
  }
  return p.depth_step.region;
}

}  // namespace

cv::Mat segmentationEdgeStrength(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                 SegmentationMethod method, const SegmentationParams& params) {
  if (method == SegmentationMethod::kTiledRansac) return {};
  if (method == SegmentationMethod::kPlanesAndObjects)
    method = SegmentationMethod::kPlanePrediction;
  const RegionParams& rp = regionParams(method, params);
  const auto w = segmentation::makeWorkingImage(depth_mm, intrinsics, rp);
  return segmentation::edgeStrength(w, method, params);
}

// The watershed methods: edges at working resolution, markers where they are low, a flood from
// the markers over the edges, and the flooded labels back at full resolution.
cv::Mat segmentDepth(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                     SegmentationMethod method, const SegmentationParams& params) {
  using namespace segmentation;
  CV_Assert(depth_mm.type() == CV_16UC1);
  if (method == SegmentationMethod::kTiledRansac) {
    return segmentTiledRansac(depth_mm, intrinsics, params.tiled_ransac);
  }
  if (method == SegmentationMethod::kPlanesAndObjects) {
    HoughPlaneDetector detector(params.planes_and_objects.planes);
    return segmentPlanesAndObjects(depth_mm, intrinsics, detector.detect(depth_mm, intrinsics),
                                   params);
  }
  const RegionParams& rp = regionParams(method, params);
  const WorkingImage w = makeWorkingImage(depth_mm, intrinsics, rp);
  cv::Mat edges, fallback;
  if (method == SegmentationMethod::kPlanePrediction) {
    const auto& pp = params.plane_prediction;
    edges = planePredictionEdges(w, pp, rp.noise, pp.curved_fallback_markers ? &fallback : nullptr);
  } else {
    edges = edgeStrength(w, method, params);
  }
  cv::Mat markers;
  const int min_marker = std::max(1, rp.min_marker_px / (w.ds * w.ds));
  const int marker_count =
      markersFromEdges(edges, rp.marker_max_edge, min_marker, markers, fallback);
  if (marker_count == 0) return cv::Mat(depth_mm.size(), CV_16UC1, cv::Scalar(0));
  flood(edges, markers);
  return finishRegions(markers, marker_count, edges, w, depth_mm, rp);
}

cv::Mat segmentWithPlanes(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                          SegmentationMethod method, const PlaneDetection& planes,
                          const SegmentationParams& params) {
  if (method != SegmentationMethod::kPlanesAndObjects)
    return segmentDepth(depth_mm, intrinsics, method, params);
  return segmentation::segmentPlanesAndObjects(depth_mm, intrinsics, planes, params);
}

}  // namespace shapesense
