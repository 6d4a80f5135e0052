#include "shapesense/core/boxes/object_boxes.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <unordered_map>

namespace shapesense {

// Pairs are collected flat and deduplicated once: most pixel pairs lie inside one segment, and
// the boundary pairs repeat.
std::map<std::uint16_t, std::set<std::uint16_t>> continuousNeighbours(const cv::Mat& labels,
                                                                      const cv::Mat& depth_mm,
                                                                      const ObjectBoxParams& params,
                                                                      const cv::Rect& within) {
  const KinectNoiseModel& noise = params.estimation.noise;
  std::vector<std::uint32_t> pairs;
  const auto consider = [&](std::uint16_t a, std::uint16_t b, std::uint16_t za, std::uint16_t zb) {
    if (a == b || a == 0 || b == 0 || za == 0 || zb == 0) return;
    const double z = 1e-3 * std::min(za, zb);
    const double max_step_m =
        params.continuity_floor_m + params.continuity_noise_steps * noise.depthStep(z);
    if (std::abs(za - zb) * 1e-3 > max_step_m) return;
    pairs.push_back(static_cast<std::uint32_t>(std::min(a, b)) << 16 | std::max(a, b));
  };
  const cv::Rect area = within.area() > 0 ? within & cv::Rect(0, 0, labels.cols, labels.rows)
                                          : cv::Rect(0, 0, labels.cols, labels.rows);
  for (int v = area.y; v + 1 < area.y + area.height; ++v) {
    const auto* l0 = labels.ptr<std::uint16_t>(v);
    const auto* l1 = labels.ptr<std::uint16_t>(v + 1);
    const auto* d0 = depth_mm.ptr<std::uint16_t>(v);
    const auto* d1 = depth_mm.ptr<std::uint16_t>(v + 1);
    for (int u = area.x; u + 1 < area.x + area.width; ++u) {
      consider(l0[u], l0[u + 1], d0[u], d0[u + 1]);
      consider(l0[u], l1[u], d0[u], d1[u]);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::map<std::uint16_t, std::set<std::uint16_t>> neighbours;
  for (const std::uint32_t pair : pairs) {
    const auto a = static_cast<std::uint16_t>(pair >> 16),
               b = static_cast<std::uint16_t>(pair & 0xFFFF);
    neighbours[a].insert(b);
    neighbours[b].insert(a);
  }
  return neighbours;
}

namespace {

// What the steps below share: the inputs and the lookups by id.
struct ObjectSearch {
  const cv::Mat& depth_mm;
  const cv::Mat& segment_labels;
  const std::vector<SegmentStatistics>& segments;
  const PlaneDetection& planes;
  const ObjectBoxParams& params;
  double image_pixels = 0;
  std::unordered_map<std::uint16_t, const DetectedPlane*> plane_by_id;
  std::unordered_map<std::uint16_t, const SegmentStatistics*> segment_by_id;

  ObjectSearch(const cv::Mat& depth, const cv::Mat& labels,
               const std::vector<SegmentStatistics>& segment_stats, const PlaneDetection& detection,
               const ObjectBoxParams& p)
      : depth_mm(depth),
        segment_labels(labels),
        segments(segment_stats),
        planes(detection),
        params(p),
        image_pixels(static_cast<double>(depth.total())) {
    for (const auto& plane : planes.planes) plane_by_id[plane.id] = &plane;
    for (const auto& segment : segments) segment_by_id[segment.id] = &segment;
  }

  // Whether `point` lies at least params.min_height_m on the camera's side of `plane`.
  bool risesAbove(const Eigen::Vector3d& point, const DetectedPlane& plane) const {
    return plane.normal.dot(point) + plane.d >= params.min_height_m;
  }

  // Whether a segment can be part of an object above `support`: not too big, in front of the
  // plane, and not mostly the plane itself.
  bool partOfObjectAbove(const SegmentStatistics& segment, const DetectedPlane& support) const {
    if (segment.pixels > params.max_image_fraction * image_pixels) return false;
    if (!risesAbove(segment.centroid, support)) return false;
    int on_support = 0;
    const cv::Rect r = segment.box;
    for (int v = r.y; v < r.y + r.height; ++v) {
      const auto* seg = segment_labels.ptr<std::uint16_t>(v);
      const auto* pl = planes.labels.ptr<std::uint16_t>(v);
      for (int u = r.x; u < r.x + r.width; ++u)
        on_support += seg[u] == segment.id && pl[u] == support.id;
    }
    return on_support <= params.max_support_overlap * segment.pixels;
  }
};

// Segments taken together: one segment, or the faces of one object.
struct SegmentRegion {
  std::vector<std::uint16_t> ids;  // sorted
  cv::Rect box;                    // bounds of their pixels
  int pixels = 0;
  bool holds(std::uint16_t label) const {
    return std::binary_search(ids.begin(), ids.end(), label);
  }
};

SegmentRegion regionOf(const SegmentStatistics& segment) {
  return {{segment.id}, segment.box, segment.pixels};
}

// Pixels of each plane region inside the segments, indexed by plane id (the labels are the
// planes' ids, and the planes are ordered by id).
std::vector<int> ownPlaneOverlap(const ObjectSearch& s, const SegmentRegion& region) {
  const std::size_t ids = s.planes.planes.empty() ? 1 : s.planes.planes.back().id + 1u;
  std::vector<int> own_overlap(ids, 0);
  const cv::Rect r = region.box;
  for (int v = r.y; v < r.y + r.height; ++v) {
    const auto* seg = s.segment_labels.ptr<std::uint16_t>(v);
    const auto* pl = s.planes.labels.ptr<std::uint16_t>(v);
    for (int u = r.x; u < r.x + r.width; ++u) {
      if (pl[u] != 0 && pl[u] < ids && region.holds(seg[u])) ++own_overlap[pl[u]];
    }
  }
  return own_overlap;
}

// The mean 3D point of the region's segments.
Eigen::Vector3d centroidOf(const ObjectSearch& s, const SegmentRegion& region) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double weight = 0.0;
  for (const std::uint16_t id : region.ids) {
    const auto it = s.segment_by_id.find(id);
    if (it == s.segment_by_id.end()) continue;
    sum += it->second->pixels * it->second->centroid;
    weight += it->second->pixels;
  }
  return weight > 0.0 ? Eigen::Vector3d(sum / weight) : sum;
}

// Drops the votes of planes the region does not rise above (by params.min_height_m), and their
// columns: such a plane is a face of something in front of the region's foot (another box
// standing before it), which hides what the region stands on.
void dropPlanesNotBelow(const ObjectSearch& s, const SegmentRegion& region,
                        std::map<std::uint16_t, int>& support_votes, int& columns) {
  const Eigen::Vector3d centroid = centroidOf(s, region);
  for (auto it = support_votes.begin(); it != support_votes.end();) {
    const auto plane = s.plane_by_id.find(it->first);
    if (plane == s.plane_by_id.end() || s.risesAbove(centroid, *plane->second)) {
      ++it;
      continue;
    }
    columns -= it->second;
    it = support_votes.erase(it);
  }
}

// The plane the segments' columns reach first below their lowest pixel (within
// support_search_px), looking through the planes the segments themselves lie on (a box face is
// a plane too, and its region may reach past the segment's edge) and leaving out planes the
// segments do not rise above; nullptr when too few reach one.
const DetectedPlane* supportBelow(const ObjectSearch& s, const SegmentRegion& region) {
  const ObjectBoxParams& params = s.params;
  const std::vector<int> own_overlap = ownPlaneOverlap(s, region);
  const auto isOwnPlane = [&](std::uint16_t plane) {
    return plane < own_overlap.size() &&
           own_overlap[plane] > params.max_support_overlap * region.pixels;
  };
  const cv::Rect r = region.box;
  std::map<std::uint16_t, int> support_votes;
  int columns = 0;
  for (int u = r.x; u < r.x + r.width; ++u) {
    int lowest = -1;
    for (int v = r.y + r.height - 1; v >= r.y; --v) {
      if (region.holds(s.segment_labels.at<std::uint16_t>(v, u))) {
        lowest = v;
        break;
      }
    }
    if (lowest < 0) continue;
    ++columns;
    const int last = std::min(s.depth_mm.rows - 1, lowest + params.support_search_px);
    for (int v = lowest + 1; v <= last; ++v) {
      const std::uint16_t plane = s.planes.labels.at<std::uint16_t>(v, u);
      if (plane != 0 && !isOwnPlane(plane) &&
          !region.holds(s.segment_labels.at<std::uint16_t>(v, u))) {
        ++support_votes[plane];
        break;
      }
    }
  }
  dropPlanesNotBelow(s, region, support_votes, columns);
  if (columns == 0 || support_votes.empty()) return nullptr;
  const auto best =
      std::max_element(support_votes.begin(), support_votes.end(),
                       [](const auto& a, const auto& b) { return a.second < b.second; });
  if (best->second < params.min_support_fraction * columns) return nullptr;
  const auto plane_it = s.plane_by_id.find(best->first);
  return plane_it == s.plane_by_id.end() ? nullptr : plane_it->second;
}

// Step 1: segments whose bottom edge rests on a plane region, the seeds of objects, with their
// support plane. Structure (walls, floor, the table itself) is never an object; checking size
// first spares scanning its large bounding box.
std::map<std::uint16_t, const DetectedPlane*> standingSegments(const ObjectSearch& s) {
  std::map<std::uint16_t, const DetectedPlane*> standing;
  for (const auto& segment : s.segments) {
    if (segment.pixels > s.params.max_image_fraction * s.image_pixels) continue;
    const DetectedPlane* support = supportBelow(s, regionOf(segment));
    if (support && s.partOfObjectAbove(segment, *support)) standing[segment.id] = support;
  }
  return standing;
}

// Step 2: the seed plus the segments joined to it without a depth step that also lie above the
// same plane (a box's top face rests on its front face, not on the table).
std::vector<std::uint16_t> objectGroup(
    const ObjectSearch& s, std::uint16_t seed, const DetectedPlane* support,
    const std::map<std::uint16_t, const DetectedPlane*>& standing,
    const std::map<std::uint16_t, std::set<std::uint16_t>>& neighbours,
    std::set<std::uint16_t>& taken) {
  std::vector<std::uint16_t> group{seed}, frontier{seed};
  taken.insert(seed);
  while (!frontier.empty()) {
    const std::uint16_t id = frontier.back();
    frontier.pop_back();
    const auto it = neighbours.find(id);
    if (it == neighbours.end()) continue;
    for (std::uint16_t next : it->second) {
      if (taken.count(next) || !s.segment_by_id.count(next)) continue;
      const auto standing_it = standing.find(next);
      if (standing_it != standing.end() && standing_it->second != support) continue;
      if (!s.partOfObjectAbove(*s.segment_by_id.at(next), *support)) continue;
      taken.insert(next);
      group.push_back(next);
      frontier.push_back(next);
    }
  }
  return group;
}

// Step 3: the box of a group's joint bounds, if the group and its box have an object's size.
std::optional<ObjectBox> boxOfGroup(const ObjectSearch& s, const CameraIntrinsics& intrinsics,
                                    const std::vector<std::uint16_t>& group,
                                    const DetectedPlane& support) {
  cv::Rect roi;
  int pixels = 0;
  for (std::uint16_t id : group) {
    roi = roi.area() == 0 ? s.segment_by_id.at(id)->box : (roi | s.segment_by_id.at(id)->box);
    pixels += s.segment_by_id.at(id)->pixels;
  }
  const double fraction = pixels / s.image_pixels;
  if (fraction < s.params.min_image_fraction || fraction > s.params.max_image_fraction) return {};
  auto estimate = estimateBox(s.depth_mm, intrinsics, roi.tl(), roi.br() - cv::Point(1, 1),
                              s.params.mode, s.params.estimation);
  auto* box = std::get_if<BoxEstimate>(&estimate);
  if (!box) return {};
  const auto& c = box->corners;
  const double size = std::max({(c[1] - c[0]).norm(), (c[3] - c[0]).norm(), (c[4] - c[0]).norm()});
  if (size > s.params.max_size_m) return {};
  return ObjectBox{group.front(), support.id, roi, *box};
}

}  // namespace

std::vector<ObjectBox> boxesOfObjectsOnPlanes(const cv::Mat& depth_mm,
                                              const CameraIntrinsics& intrinsics,
                                              const cv::Mat& segment_labels,
                                              const std::vector<SegmentStatistics>& segments,
                                              const PlaneDetection& planes,
                                              const ObjectBoxParams& params) {
  CV_Assert(segment_labels.type() == CV_16UC1 && planes.labels.type() == CV_16UC1);
  CV_Assert(segment_labels.size() == depth_mm.size() && planes.labels.size() == depth_mm.size());
  const ObjectSearch search(depth_mm, segment_labels, segments, planes, params);
  const auto standing = standingSegments(search);
  const auto neighbours = continuousNeighbours(segment_labels, depth_mm, params);
  std::set<std::uint16_t> taken;
  std::vector<ObjectBox> boxes;
  for (const auto& [seed, support] : standing) {
    if (taken.count(seed)) continue;
    const auto group = objectGroup(search, seed, support, standing, neighbours, taken);
    if (auto box = boxOfGroup(search, intrinsics, group, *support)) boxes.push_back(*box);
  }
  return boxes;
}

const DetectedPlane* supportPlaneBelow(const cv::Mat& depth_mm, const cv::Mat& segment_labels,
                                       const std::vector<SegmentStatistics>& segments,
                                       const PlaneDetection& planes,
                                       const std::vector<std::uint16_t>& segment_ids,
                                       const ObjectBoxParams& params) {
  CV_Assert(segment_labels.type() == CV_16UC1 && planes.labels.type() == CV_16UC1);
  CV_Assert(segment_labels.size() == depth_mm.size() && planes.labels.size() == depth_mm.size());
  const ObjectSearch search(depth_mm, segment_labels, segments, planes, params);
  SegmentRegion region;
  for (const std::uint16_t id : segment_ids) {
    const auto it = search.segment_by_id.find(id);
    if (it == search.segment_by_id.end()) continue;
    region.ids.push_back(id);
    region.box = region.box.area() == 0 ? it->second->box : (region.box | it->second->box);
    region.pixels += it->second->pixels;
  }
  if (region.ids.empty()) return nullptr;
  std::sort(region.ids.begin(), region.ids.end());
  return supportBelow(search, region);
}

}  // namespace shapesense
