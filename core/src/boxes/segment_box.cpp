#include "shapesense/core/boxes/segment_box.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/geometry/union_find.h"

namespace shapesense {
namespace {

BoxEstimationFailure noObject(const std::string& why) {
  return {BoxEstimationError::kNoValidDepth, why};
}

// A box's frame: orthonormal, right x down = forward (the camera's own axes when nothing
// better is known).
struct BoxAxes {
  Eigen::Vector3d right = Eigen::Vector3d::UnitX();
  Eigen::Vector3d down = Eigen::Vector3d::UnitY();
  Eigen::Vector3d forward = Eigen::Vector3d::UnitZ();
};

// How much of what the segmentation joined to the object is the object's (see objectUnderRoi).
enum class ObjectExtent { kAsSegmented, kTight };

// Step 1, the continuity rule: the covered segments fall into groups joined through
// depth-continuous contacts. For the tight extent, when some segment lies mostly inside the ROI
// (a face of the object), only groups holding such faces are the object, each with at least
// `min_group_share` of the largest one's pixels (an ROI drawn around a stack holds several
// objects); the others are what shows between or behind them (a patch of wall, a strip of
// floor); and a segment only clipped by the ROI does not join with less than
// `min_clipped_share_of_faces` of its group's faces' pixels: a sliver of the next object seen
// past this one's edge.
std::vector<RoiSegment> mainGroups(const std::vector<RoiSegment>& covered,
                                   const cv::Mat& segment_labels, const cv::Mat& depth_mm,
                                   const cv::Rect& bounds, const SegmentBoxParams& params,
                                   ObjectExtent extent) {
  const auto neighbours = continuousNeighbours(segment_labels, depth_mm, params.support, bounds);
  std::map<std::uint16_t, std::size_t> index_of;
  for (std::size_t i = 0; i < covered.size(); ++i) index_of[covered[i].id] = i;
  std::vector<int> parent(covered.size());
  resetSets(parent);
  for (const auto& [id, touching] : neighbours) {
    const auto a = index_of.find(id);
    if (a == index_of.end()) continue;
    for (const std::uint16_t other : touching) {
      const auto b = index_of.find(other);
      if (b != index_of.end())
        unite(parent, static_cast<int>(a->second), static_cast<int>(b->second));
    }
  }
  struct Group {
    int pixels = 0;
    int face_pixels = 0;  ///< of its whole segments
  };
  std::map<int, Group> groups;
  for (std::size_t i = 0; i < covered.size(); ++i) {
    Group& group = groups[findRoot(parent, static_cast<int>(i))];
    group.pixels += covered[i].pixels;
    if (covered[i].whole) group.face_pixels += covered[i].pixels;
  }
  const bool tight = extent == ObjectExtent::kTight;
  const bool any_faces =
      tight && std::any_of(covered.begin(), covered.end(), [](const auto& s) { return s.whole; });
  const auto candidate = [&](const Group& group) { return !any_faces || group.face_pixels > 0; };
  int largest = 0;
  for (const auto& [root, group] : groups)
    if (candidate(group)) largest = std::max(largest, group.pixels);
  std::vector<RoiSegment> kept;
  for (std::size_t i = 0; i < covered.size(); ++i) {
    const Group& group = groups[findRoot(parent, static_cast<int>(i))];
    if (!candidate(group) || group.pixels < params.min_group_share * largest) continue;
    if (tight && !covered[i].whole &&
        covered[i].pixels < params.min_clipped_share_of_faces * group.face_pixels)
      continue;
    kept.push_back(covered[i]);
  }
  return kept;
}

// Step 3 reads the segments' 3D points and sorts them by the support plane: above its noise
// band, inside it, below it.
struct ObjectPixels {
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Point> pixels;
};

struct SupportedPoints {
  ObjectPixels all;
  ObjectPixels above;  ///< off the support's band on the camera's side (empty without support)
  std::size_t below = 0;
};

SupportedPoints objectPoints(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                             const cv::Mat& segment_labels, const std::vector<RoiSegment>& object,
                             cv::Rect roi, cv::Rect bounds, const DetectedPlane* support,
                             const SegmentBoxParams& params) {
  enum Membership : std::uint8_t { kNone, kWhole, kInsideRoi };
  std::vector<std::uint8_t> membership(65536, kNone);
  for (const auto& segment : object) membership[segment.id] = segment.whole ? kWhole : kInsideRoi;
  const auto isObject = [&](std::uint16_t label, int u, int v) {
    const std::uint8_t m = membership[label];
    return m == kWhole || (m == kInsideRoi && roi.contains({u, v}));
  };
  const double max_depth_m = params.support.estimation.max_valid_depth_m;
  const KinectNoiseModel& noise = params.support.estimation.noise;
  SupportedPoints out;
  out.all.points.reserve(static_cast<std::size_t>(bounds.area()));
  if (support) out.above.points.reserve(static_cast<std::size_t>(bounds.area()));
  for (int v = bounds.y; v < bounds.y + bounds.height; ++v) {
    const auto* label = segment_labels.ptr<std::uint16_t>(v);
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    for (int u = bounds.x; u < bounds.x + bounds.width; ++u) {
      if (depth[u] == 0 || label[u] == 0 || !isObject(label[u], u, v)) continue;
      const double z = 1e-3 * depth[u];
      if (z > max_depth_m) continue;
      const Eigen::Vector3d point = intrinsics.backproject(u, v, z);
      out.all.points.push_back(point);
      out.all.pixels.emplace_back(u, v);
      if (!support) continue;
      const double band =
          std::max(params.support_band_floor_m, params.support_band_steps * noise.depthStep(z));
      const double height = support->normal.dot(point) + support->d;
      if (height > band) {
        out.above.points.push_back(point);
        out.above.pixels.emplace_back(u, v);
      }
      out.below += height < -band;
    }
  }
  return out;
}

// The points of a footprint that can be corners of its convex hull: all but those strictly
// inside the polygon of its extreme points in eight directions (Akl-Toussaint). minAreaRect
// orders its input to build that hull, and a filled footprint has a frame's worth of points.
std::vector<cv::Point2f> hullCandidates(const std::vector<cv::Point2f>& footprint) {
  constexpr int kDirections = 8;
  std::array<cv::Point2f, kDirections> extreme;
  std::array<double, kDirections> best;
  best.fill(-std::numeric_limits<double>::infinity());
  std::array<cv::Point2d, kDirections> direction;
  for (int i = 0; i < kDirections; ++i) {
    const double angle = 2.0 * CV_PI * i / kDirections;
    direction[static_cast<std::size_t>(i)] = {std::cos(angle), std::sin(angle)};
  }
  for (const cv::Point2f& p : footprint) {
    for (std::size_t i = 0; i < kDirections; ++i) {
      const double reach = direction[i].x * p.x + direction[i].y * p.y;
      if (reach > best[i]) {
        best[i] = reach;
        extreme[i] = p;
      }
    }
  }
  // The extremes in order of direction go round the hull counter-clockwise.
  std::vector<std::pair<cv::Point2d, cv::Point2d>> edges;
  for (std::size_t i = 0; i < kDirections; ++i) {
    const cv::Point2d from = extreme[i], to = extreme[(i + 1) % kDirections];
    if (from != to) edges.emplace_back(from, to);
  }
  if (edges.size() < 3) return footprint;  // no polygon with an inside: a line or a point
  const auto strictlyInside = [&](const cv::Point2f& p) {
    return std::all_of(edges.begin(), edges.end(), [&](const auto& edge) {
      const cv::Point2d along = edge.second - edge.first;
      const cv::Point2d to_point = cv::Point2d(p) - edge.first;
      return along.x * to_point.y - along.y * to_point.x > 0.0;
    });
  };
  std::vector<cv::Point2f> candidates;
  for (const cv::Point2f& p : footprint)
    if (!strictlyInside(p)) candidates.push_back(p);
  return candidates;
}

// Step 4, on a support: vertical axis along the plane's normal, footprint the smallest
// rectangle around the points cast onto the plane, "right" the footprint side nearer the
// camera's x axis.
BoxAxes uprightAxes(const std::vector<Eigen::Vector3d>& points, const DetectedPlane& support) {
  const Eigen::Vector3d down = -support.normal;
  Eigen::Vector3d across = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(down) * down;
  if (across.norm() < 1e-3)
    across = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(down) * down;
  across.normalize();
  const Eigen::Vector3d along = across.cross(down);
  std::vector<cv::Point2f> footprint;
  footprint.reserve(points.size());
  for (const auto& p : points)
    footprint.emplace_back(static_cast<float>(p.dot(across)), static_cast<float>(p.dot(along)));
  const double angle = cv::minAreaRect(hullCandidates(footprint)).angle * CV_PI / 180.0;
  const Eigen::Vector3d side_a = std::cos(angle) * across + std::sin(angle) * along;
  const Eigen::Vector3d side_b = down.cross(side_a);
  BoxAxes axes;
  axes.down = down;
  axes.right = std::abs(side_a.x()) >= std::abs(side_b.x()) ? side_a : side_b;
  if (axes.right.x() < 0.0) axes.right = -axes.right;
  axes.forward = axes.right.cross(axes.down);
  return axes;
}

// Step 4: the box along `axes` around the points; on a support, reaching down to its plane
// when the object's foot is near it.
BoxCorners boxAlong(const BoxAxes& axes, const std::vector<Eigen::Vector3d>& points,
                    const DetectedPlane* support, const SegmentBoxParams& params) {
  std::array<Eigen::Vector3d, 3> frame{axes.right, axes.down, axes.forward};
  std::array<std::pair<double, double>, 3> range;
  std::vector<double> coordinate(points.size());
  // The gap follows the sensor's noise at the points' median range, read off every 16th point.
  std::vector<double> ranges;
  ranges.reserve(points.size() / 16 + 1);
  for (std::size_t i = 0; i < points.size(); i += 16) ranges.push_back(points[i].z());
  const double max_gap = std::max(
      params.max_gap_floor_m,
      params.max_gap_steps * params.support.estimation.noise.depthStep(quantile(ranges, 0.5)));
  for (std::size_t axis = 0; axis < 3; ++axis) {
    for (std::size_t i = 0; i < points.size(); ++i) coordinate[i] = points[i].dot(frame[axis]);
    const auto trimmed = trimmedRange(coordinate, params.trim_fraction);
    const auto dense = denseRange(coordinate, max_gap, params.min_cluster_share);
    range[axis] = {std::max(trimmed.first, dense.first), std::min(trimmed.second, dense.second)};
  }
  if (support) {
    // Along `down` = -n the plane lies at d; the object's lowest point at range[1].second.
    const double plane_at = support->d;
    if (plane_at - range[1].second <= params.max_foot_gap_m)
      range[1].second = std::max(range[1].second, plane_at);
  }
  BoxCorners corners;
  const auto corner = [&](bool right, bool bottom, bool back) {
    return (right ? range[0].second : range[0].first) * axes.right +
           (bottom ? range[1].second : range[1].first) * axes.down +
           (back ? range[2].second : range[2].first) * axes.forward;
  };
  for (int back = 0; back < 2; ++back) {
    corners[static_cast<std::size_t>(4 * back + 0)] = corner(false, false, back);
    corners[static_cast<std::size_t>(4 * back + 1)] = corner(true, false, back);
    corners[static_cast<std::size_t>(4 * back + 2)] = corner(true, true, back);
    corners[static_cast<std::size_t>(4 * back + 3)] = corner(false, true, back);
  }
  return corners;
}

RoiDepthStatistics pointStatistics(const cv::Mat& depth_mm, const cv::Rect& roi,
                                   const std::vector<Eigen::Vector3d>& points,
                                   const BoxCorners& corners, double max_depth_m) {
  RoiDepthStatistics stats;
  const cv::Mat roi_depth = depth_mm(roi);
  for (int v = 0; v < roi_depth.rows; ++v) {
    const auto* depth = roi_depth.ptr<std::uint16_t>(v);
    for (int u = 0; u < roi_depth.cols; ++u)
      stats.valid_pixels += depth[u] != 0 && 1e-3 * depth[u] <= max_depth_m;
  }
  std::vector<double> z(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) z[i] = points[i].z();
  stats.used_pixels = static_cast<int>(z.size());
  double sum = 0.0, sum_sq = 0.0;
  for (double value : z) {
    sum += value;
    sum_sq += value * value;
  }
  const double n = static_cast<double>(z.size());
  stats.mean_m = sum / n;
  stats.std_m = std::sqrt(std::max(0.0, sum_sq / n - stats.mean_m * stats.mean_m));
  const auto [min_it, max_it] = std::minmax_element(z.begin(), z.end());
  stats.min_m = *min_it;
  stats.max_m = *max_it;
  std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(z.size() / 2), z.end());
  stats.median_m = z[z.size() / 2];
  stats.near_m = corners[0].z();
  stats.far_m = corners[0].z();
  for (const auto& c : corners) {
    stats.near_m = std::min(stats.near_m, c.z());
    stats.far_m = std::max(stats.far_m, c.z());
  }
  return stats;
}

// Readings (pixels with depth, as the segment statistics count them) inside `roi` per label of
// `labels` (CV_16UC1; index = label); with `within` given, only where it holds `within_label`.
std::vector<int> readingsPerLabel(const cv::Mat& depth_mm, const cv::Mat& labels,
                                  const cv::Rect& roi, const cv::Mat& within = {},
                                  std::uint16_t within_label = 0) {
  std::vector<int> count(65536, 0);
  for (int v = roi.y; v < roi.y + roi.height; ++v) {
    const auto* label = labels.ptr<std::uint16_t>(v);
    const auto* depth = depth_mm.ptr<std::uint16_t>(v);
    const auto* where = within.empty() ? nullptr : within.ptr<std::uint16_t>(v);
    for (int u = roi.x; u < roi.x + roi.width; ++u)
      count[label[u]] += depth[u] != 0 && (!where || where[u] == within_label);
  }
  return count;
}

// The label other than 0 with the most readings (the lowest such label on a tie); 0 for none.
std::uint16_t mostRead(const std::vector<int>& readings) {
  std::size_t best = 0;
  for (std::size_t label = 1; label < readings.size(); ++label)
    if (readings[label] > 0 && (best == 0 || readings[label] > readings[best])) best = label;
  return static_cast<std::uint16_t>(best);
}

}  // namespace

std::vector<RoiSegment> segmentsUnderRoi(const cv::Mat& depth_mm, const cv::Mat& segment_labels,
                                         const std::vector<SegmentStatistics>& segments,
                                         const cv::Rect& roi, const SegmentBoxParams& params) {
  const std::vector<int> inside = readingsPerLabel(depth_mm, segment_labels, roi);
  std::vector<RoiSegment> covered;
  for (const auto& segment : segments) {
    if (segment.id == 0 || segment.pixels <= 0) continue;
    const double share = static_cast<double>(inside[segment.id]) / segment.pixels;
    if (share >= params.min_inside_fraction)
      covered.push_back({segment.id, true, segment.pixels});
    else if (share >= params.min_clipped_fraction)
      covered.push_back({segment.id, false, inside[segment.id]});
  }
  std::sort(covered.begin(), covered.end(),
            [](const RoiSegment& a, const RoiSegment& b) { return a.id < b.id; });
  return covered;
}

namespace {

struct FoundObject {
  ObjectPixels pixels;
  const DetectedPlane* support = nullptr;
};

// The segment holding most of the ROI's depth readings, clipped to the ROI, and the plane
// region most of that part lies on.
struct RoiSurface {
  RoiSegment segment;
  const DetectedPlane* plane = nullptr;
};

std::optional<RoiSurface> surfaceUnderRoi(const cv::Mat& depth_mm, const cv::Mat& segment_labels,
                                          const PlaneDetection& planes, const cv::Rect& roi) {
  const std::vector<int> segment_readings = readingsPerLabel(depth_mm, segment_labels, roi);
  const std::uint16_t widest = mostRead(segment_readings);
  if (widest == 0) return std::nullopt;
  const std::uint16_t plane_id =
      mostRead(readingsPerLabel(depth_mm, planes.labels, roi, segment_labels, widest));
  const auto plane = std::find_if(planes.planes.begin(), planes.planes.end(),
                                  [&](const DetectedPlane& p) { return p.id == plane_id; });
  if (plane_id == 0 || plane == planes.planes.end()) return std::nullopt;
  return RoiSurface{{widest, false, segment_readings[widest]}, &*plane};
}

// Cuts the whole segments to the ROI grown by `whole_segment_reach` of its size on each side:
// a segment mostly inside the ROI is the object's face, but the segmentation may have joined to
// it a strip of something else that runs on far outside (the front edge of the table a tin
// stands at). When some whole segment of `covered` reaches past that, writes the cut labels and
// their statistics, sets the whole segments' pixels to what is left of them, and returns true;
// otherwise leaves everything as it is.
bool cutWholeSegmentsNearRoi(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                             const cv::Mat& segment_labels,
                             const std::vector<SegmentStatistics>& segments, const cv::Rect& roi,
                             const SegmentBoxParams& params, std::vector<RoiSegment>& covered,
                             cv::Mat& cut_labels, std::vector<SegmentStatistics>& cut_segments) {
  const int dx = static_cast<int>(std::ceil(params.whole_segment_reach * roi.width));
  const int dy = static_cast<int>(std::ceil(params.whole_segment_reach * roi.height));
  const cv::Rect reach = cv::Rect(roi.x - dx, roi.y - dy, roi.width + 2 * dx, roi.height + 2 * dy) &
                         cv::Rect(0, 0, segment_labels.cols, segment_labels.rows);
  const auto statisticsOf = [](const std::vector<SegmentStatistics>& all, std::uint16_t id) {
    const auto it = std::find_if(all.begin(), all.end(),
                                 [&](const SegmentStatistics& s) { return s.id == id; });
    return it == all.end() ? nullptr : &*it;
  };
  const bool beyond = std::any_of(covered.begin(), covered.end(), [&](const RoiSegment& c) {
    const SegmentStatistics* stats = c.whole ? statisticsOf(segments, c.id) : nullptr;
    return stats && (stats->box & reach) != stats->box;
  });
  if (!beyond) return false;
  cut_labels = cv::Mat::zeros(segment_labels.size(), CV_16UC1);
  segment_labels(reach).copyTo(cut_labels(reach));
  cut_segments = computeSegmentStatistics(cut_labels, depth_mm, intrinsics);
  for (RoiSegment& segment : covered) {
    if (!segment.whole) continue;
    const SegmentStatistics* stats = statisticsOf(cut_segments, segment.id);
    segment.pixels = stats ? stats->pixels : 0;
  }
  return true;
}

// Steps 1-3 of boxFromSegments.
std::variant<FoundObject, BoxEstimationFailure> findRoiObject(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics, cv::Point p1, cv::Point p2,
    const cv::Mat& segment_labels, const std::vector<SegmentStatistics>& segments,
    const PlaneDetection& planes, const SegmentBoxParams& params, ObjectExtent extent) {
  if (auto failure = checkRoiRequest(depth_mm, intrinsics, p1, p2)) return *failure;
  if (segment_labels.type() != CV_16UC1 || segment_labels.size() != depth_mm.size() ||
      planes.labels.type() != CV_16UC1 || planes.labels.size() != depth_mm.size()) {
    return BoxEstimationFailure{BoxEstimationError::kInvalidArgument,
                                "segment and plane labels must be CV_16UC1 images of the depth "
                                "image's size"};
  }
  const cv::Rect roi(cv::Point(std::min(p1.x, p2.x), std::min(p1.y, p2.y)),
                     cv::Point(std::max(p1.x, p2.x) + 1, std::max(p1.y, p2.y) + 1));
  std::vector<RoiSegment> object =
      segmentsUnderRoi(depth_mm, segment_labels, segments, roi, params);
  // For the tight extent, whole segments count only near the ROI.
  cv::Mat cut_labels;
  std::vector<SegmentStatistics> cut_segments;
  const bool cut = extent == ObjectExtent::kTight &&
                   cutWholeSegmentsNearRoi(depth_mm, intrinsics, segment_labels, segments, roi,
                                           params, object, cut_labels, cut_segments);
  const cv::Mat& labels = cut ? cut_labels : segment_labels;
  const std::vector<SegmentStatistics>& statistics = cut ? cut_segments : segments;
  cv::Rect bounds = roi;
  const DetectedPlane* support = nullptr;
  const bool part_of_larger_segment = object.empty();
  if (part_of_larger_segment) {
    // The object is part of a larger segment: one a few depth steps proud of what it lies on
    // (a book, a lid) is not parted from it. Its points are those of that segment inside the
    // ROI that rise off the plane under them (step 3).
    const auto surface = surfaceUnderRoi(depth_mm, segment_labels, planes, roi);
    if (!surface) {
      return noObject("no segment lies mostly inside the ROI: draw it around the whole object");
    }
    object.push_back(surface->segment);
    support = surface->plane;
  } else {
    for (const auto& segment : statistics) {
      const auto it = std::find_if(object.begin(), object.end(),
                                   [&](const RoiSegment& o) { return o.id == segment.id; });
      if (it != object.end() && it->whole) bounds |= segment.box;
    }
    object = mainGroups(object, labels, depth_mm, bounds, params, extent);
    // The support is what the object's own faces stand on: a clipped segment may be the table.
    std::vector<std::uint16_t> ids;
    for (const auto& segment : object)
      if (segment.whole) ids.push_back(segment.id);
    if (ids.empty())
      for (const auto& segment : object) ids.push_back(segment.id);
    support = supportPlaneBelow(depth_mm, labels, statistics, planes, ids, params.support);
  }
  SupportedPoints read =
      objectPoints(depth_mm, intrinsics, labels, object, roi, bounds, support, params);
  if (read.all.points.empty()) return noObject("the ROI's segments have no depth reading");
  // An object has only noise below the plane it stands on: a tenth of its points below say the
  // plane is not its support (an object beyond the table's far edge, seen over it; a shelf or
  // another object's top at half its height).
  constexpr double kMaxBelowShare = 0.1;
  if (support && read.below > kMaxBelowShare * static_cast<double>(read.all.points.size()))
    support = nullptr;
  // Nearly all of it within the support's band: a board or a lid lying flat, only a few depth
  // steps proud of the table at that range.
  constexpr double kMinAboveShare = 0.1;
  const bool stands_out =
      support &&
      read.above.points.size() >= kMinAboveShare * static_cast<double>(read.all.points.size());
  if (part_of_larger_segment && !stands_out) {
    return noObject(
        "no segment lies mostly inside the ROI, and nothing in it rises off the surface it "
        "shows: draw it around the whole object");
  }
  ObjectPixels found = stands_out ? std::move(read.above) : std::move(read.all);
  return FoundObject{std::move(found), support};
}

}  // namespace

std::variant<RoiObject, BoxEstimationFailure> objectUnderRoi(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics, cv::Point p1, cv::Point p2,
    const cv::Mat& segment_labels, const std::vector<SegmentStatistics>& segments,
    const PlaneDetection& planes, const SegmentBoxParams& params) {
  auto found = findRoiObject(depth_mm, intrinsics, p1, p2, segment_labels, segments, planes, params,
                             ObjectExtent::kAsSegmented);
  if (auto* failure = std::get_if<BoxEstimationFailure>(&found)) return *failure;
  FoundObject& object = std::get<FoundObject>(found);
  RoiObject out;
  out.mask = cv::Mat::zeros(depth_mm.size(), CV_8UC1);
  for (const cv::Point& pixel : object.pixels.pixels) out.mask.at<std::uint8_t>(pixel) = 255;
  out.points = std::move(object.pixels.points);
  out.support = object.support;
  return out;
}

std::variant<BoxEstimate, BoxEstimationFailure> boxFromSegments(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics, cv::Point p1, cv::Point p2,
    const cv::Mat& segment_labels, const std::vector<SegmentStatistics>& segments,
    const PlaneDetection& planes, const SegmentBoxParams& params) {
  // Not objectUnderRoi: the box needs the points, not a frame-sized mask of them.
  auto found = findRoiObject(depth_mm, intrinsics, p1, p2, segment_labels, segments, planes, params,
                             ObjectExtent::kTight);
  if (auto* failure = std::get_if<BoxEstimationFailure>(&found)) return *failure;
  const FoundObject& object = std::get<FoundObject>(found);
  const cv::Rect roi(cv::Point(std::min(p1.x, p2.x), std::min(p1.y, p2.y)),
                     cv::Point(std::max(p1.x, p2.x) + 1, std::max(p1.y, p2.y) + 1));
  const std::vector<Eigen::Vector3d>& points = object.pixels.points;
  const BoxAxes axes = object.support ? uprightAxes(points, *object.support) : BoxAxes{};
  BoxEstimate out;
  out.mode = BoxMode::kSegments;
  out.corners = boxAlong(axes, points, object.support, params);
  out.stats = pointStatistics(depth_mm, roi, points, out.corners,
                              params.support.estimation.max_valid_depth_m);
  return out;
}

}  // namespace shapesense
