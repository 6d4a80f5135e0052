#include "shapesense/core/boxes/object_boxes.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>

namespace shapesense {
namespace {

// Which segments touch which, across depth-continuous pixel pairs only (an object's faces touch;
// an object and the wall behind it only meet across a depth step). Pairs are collected flat and
// deduplicated once: most pixel pairs lie inside one segment, and the boundary pairs repeat.
std::map<std::uint16_t, std::set<std::uint16_t>> continuousNeighbours(
    const cv::Mat& labels, const cv::Mat& depth_mm, const KinectNoiseModel& noise) {
  std::vector<std::uint32_t> pairs;
  const auto consider = [&](std::uint16_t a, std::uint16_t b, std::uint16_t za, std::uint16_t zb) {
    if (a == b || a == 0 || b == 0 || za == 0 || zb == 0) return;
    const double z = 1e-3 * std::min(za, zb);
    if (std::abs(za - zb) * 1e-3 > 0.01 + 3 * noise.depthStep(z)) return;
    pairs.push_back(static_cast<std::uint32_t>(std::min(a, b)) << 16 | std::max(a, b));
  };
  for (int v = 0; v + 1 < labels.rows; ++v) {
    const auto* l0 = labels.ptr<std::uint16_t>(v);
    const auto* l1 = labels.ptr<std::uint16_t>(v + 1);
    const auto* d0 = depth_mm.ptr<std::uint16_t>(v);
    const auto* d1 = depth_mm.ptr<std::uint16_t>(v + 1);
    for (int u = 0; u + 1 < labels.cols; ++u) {
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

}  // namespace

std::vector<ObjectBox> boxesOfObjectsOnPlanes(const cv::Mat& depth_mm,
                                              const CameraIntrinsics& intrinsics,
                                              const cv::Mat& segment_labels,
                                              const std::vector<SegmentStatistics>& segments,
                                              const PlaneDetection& planes,
                                              const ObjectBoxParams& params) {
  CV_Assert(segment_labels.type() == CV_16UC1 && planes.labels.type() == CV_16UC1);
  CV_Assert(segment_labels.size() == depth_mm.size() && planes.labels.size() == depth_mm.size());
  const double image_pixels = static_cast<double>(depth_mm.total());
  std::unordered_map<std::uint16_t, const DetectedPlane*> plane_by_id;
  for (const auto& plane : planes.planes) plane_by_id[plane.id] = &plane;
  std::unordered_map<std::uint16_t, const SegmentStatistics*> segment_by_id;
  for (const auto& segment : segments) segment_by_id[segment.id] = &segment;

  // Whether a segment can be part of an object above `support`: not too big, in front of the
  // plane, and not mostly the plane itself.
  const auto partOfObjectAbove = [&](const SegmentStatistics& segment,
                                     const DetectedPlane& support) {
    if (segment.pixels > params.max_image_fraction * image_pixels) return false;
    if (support.normal.dot(segment.centroid) + support.d < params.min_height_m) return false;
    int on_support = 0;
    const cv::Rect r = segment.box;
    for (int v = r.y; v < r.y + r.height; ++v) {
      const auto* seg = segment_labels.ptr<std::uint16_t>(v);
      const auto* pl = planes.labels.ptr<std::uint16_t>(v);
      for (int u = r.x; u < r.x + r.width; ++u)
        on_support += seg[u] == segment.id && pl[u] == support.id;
    }
    return on_support <= params.max_support_overlap * segment.pixels;
  };

  // 1. Segments whose bottom edge rests on a plane region: the seeds of objects. The planes the
  //    segment itself lies on (a box face is a plane too, and its region may reach past the
  //    segment's edge) are looked through, not taken as support.
  std::map<std::uint16_t, const DetectedPlane*> standing;
  for (const auto& segment : segments) {
    // Structure (walls, floor, the table itself) is never an object; checking first spares
    // scanning its large bounding box.
    if (segment.pixels > params.max_image_fraction * image_pixels) continue;
    const cv::Rect r = segment.box;
    std::map<std::uint16_t, int> own_overlap;
    for (int v = r.y; v < r.y + r.height; ++v) {
      const auto* seg = segment_labels.ptr<std::uint16_t>(v);
      const auto* pl = planes.labels.ptr<std::uint16_t>(v);
      for (int u = r.x; u < r.x + r.width; ++u) {
        if (seg[u] == segment.id && pl[u] != 0) ++own_overlap[pl[u]];
      }
    }
    const auto isOwnPlane = [&](std::uint16_t plane) {
      const auto it = own_overlap.find(plane);
      return it != own_overlap.end() && it->second > params.max_support_overlap * segment.pixels;
    };
    std::map<std::uint16_t, int> support_votes;
    int columns = 0;
    for (int u = r.x; u < r.x + r.width; ++u) {
      int lowest = -1;
      for (int v = r.y + r.height - 1; v >= r.y; --v) {
        if (segment_labels.at<std::uint16_t>(v, u) == segment.id) {
          lowest = v;
          break;
        }
      }
      if (lowest < 0) continue;
      ++columns;
      const int last = std::min(depth_mm.rows - 1, lowest + params.support_search_px);
      for (int v = lowest + 1; v <= last; ++v) {
        const std::uint16_t plane = planes.labels.at<std::uint16_t>(v, u);
        if (plane != 0 && !isOwnPlane(plane) &&
            segment_labels.at<std::uint16_t>(v, u) != segment.id) {
          ++support_votes[plane];
          break;
        }
      }
    }
    if (columns == 0 || support_votes.empty()) continue;
    const auto best =
        std::max_element(support_votes.begin(), support_votes.end(),
                         [](const auto& a, const auto& b) { return a.second < b.second; });
    if (best->second < params.min_support_fraction * columns) continue;
    const auto plane_it = plane_by_id.find(best->first);
    if (plane_it == plane_by_id.end() || !partOfObjectAbove(segment, *plane_it->second)) continue;
    standing[segment.id] = plane_it->second;
  }

  // 2. An object is a seed plus the segments joined to it without a depth step that also lie
  //    above the same plane (a box's top face rests on its front face, not on the table).
  const auto neighbours = continuousNeighbours(segment_labels, depth_mm, params.estimation.noise);
  std::set<std::uint16_t> taken;
  std::vector<ObjectBox> boxes;
  for (const auto& [seed, support] : standing) {
    if (taken.count(seed)) continue;
    std::vector<std::uint16_t> group{seed}, frontier{seed};
    taken.insert(seed);
    while (!frontier.empty()) {
      const std::uint16_t id = frontier.back();
      frontier.pop_back();
      const auto it = neighbours.find(id);
      if (it == neighbours.end()) continue;
      for (std::uint16_t next : it->second) {
        if (taken.count(next) || !segment_by_id.count(next)) continue;
        const auto standing_it = standing.find(next);
        if (standing_it != standing.end() && standing_it->second != support) continue;
        if (!partOfObjectAbove(*segment_by_id.at(next), *support)) continue;
        taken.insert(next);
        group.push_back(next);
        frontier.push_back(next);
      }
    }
    cv::Rect roi;
    int pixels = 0;
    for (std::uint16_t id : group) {
      roi = roi.area() == 0 ? segment_by_id.at(id)->box : (roi | segment_by_id.at(id)->box);
      pixels += segment_by_id.at(id)->pixels;
    }
    const double fraction = pixels / image_pixels;
    if (fraction < params.min_image_fraction || fraction > params.max_image_fraction) continue;
    auto estimate = estimateBox(depth_mm, intrinsics, roi.tl(), roi.br() - cv::Point(1, 1),
                                params.mode, params.estimation);
    auto* box = std::get_if<BoxEstimate>(&estimate);
    if (!box) continue;
    const auto& c = box->corners;
    const double size =
        std::max({(c[1] - c[0]).norm(), (c[3] - c[0]).norm(), (c[4] - c[0]).norm()});
    if (size > params.max_size_m) continue;
    boxes.push_back({seed, support->id, roi, *box});
  }
  return boxes;
}

}  // namespace shapesense
