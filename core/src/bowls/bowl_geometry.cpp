#include "shapesense/core/bowls/bowl_geometry.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "shapesense/core/geometry/depth_step.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense {

namespace {

struct SupportPlane {
  Eigen::Vector3d normal;
  double d = 0;
  std::uint16_t id = 0;
};

/// The object's points in the support's frame.
struct Profile {
  std::vector<double> heights;  ///< above the support (m)
  std::vector<double> across;   ///< along the horizontal axis across the line of sight (m)
  std::vector<double> along;    ///< along the horizontal axis away from the camera (m)
  Eigen::Vector3d across_axis = Eigen::Vector3d::UnitX();
  Eigen::Vector3d along_axis = Eigen::Vector3d::UnitZ();
};

constexpr int kMaxSupportSamples = 1200;
constexpr int kMinBandPoints = 5;

/// Where a support shows: beside the lower half of the box and below it (a bowl stands on it;
/// objects in front may hide the bowl's foot, so the window reaches the surface beside it).
cv::Rect supportWindow(const cv::Rect& box, const cv::Size& image) {
  const cv::Point tl(box.x - box.width, box.y + box.height / 2);
  const cv::Point br(box.x + 2 * box.width, box.y + 2 * box.height);
  return cv::Rect(tl, br) & cv::Rect(cv::Point(0, 0), image);
}

/// The smallest whole pixel step at which the box holds at most `max_samples` samples.
int sampleStep(const cv::Rect& box, int max_samples) {
  if (max_samples <= 0) return 1;
  return std::max(
      1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(box.area()) / max_samples))));
}

/// Labelled pixels of each plane in the window but outside the box, sampled on a grid of
/// about kMaxSupportSamples.
std::map<std::uint16_t, int> planePixelsBeside(const cv::Mat& labels, const cv::Rect& window,
                                               const cv::Rect& box) {
  std::map<std::uint16_t, int> counts;
  if (window.empty()) return counts;
  const int step = sampleStep(window, kMaxSupportSamples);
  for (int v = window.y; v < window.br().y; v += step) {
    const auto* row = labels.ptr<std::uint16_t>(v);
    for (int u = window.x; u < window.br().x; u += step)
      if (row[u] != 0 && !box.contains({u, v})) ++counts[row[u]];
  }
  return counts;
}

/// A plane that lies within the object's box (a bowl's flat rim, a tin's lid) is part of it.
bool reachesBeyond(const DetectedPlane& plane, const cv::Rect& box) {
  const cv::Rect grown(box.x - box.width / 4, box.y - box.height / 4, box.width * 3 / 2,
                       box.height * 3 / 2);
  return (plane.box & grown) != plane.box;
}

/// The median reading of the box's central half: a point of the object the support must hold.
std::optional<Eigen::Vector3d> centralPoint(const cv::Mat& depth_mm,
                                            const CameraIntrinsics& intrinsics,
                                            const cv::Rect& box) {
  const cv::Rect centre(box.x + box.width / 4, box.y + box.height / 4, std::max(1, box.width / 2),
                        std::max(1, box.height / 2));
  std::vector<std::uint16_t> depths;
  for (int v = centre.y; v < centre.br().y; ++v)
    for (int u = centre.x; u < centre.br().x; ++u)
      if (const auto mm = depth_mm.at<std::uint16_t>(v, u); mm != 0) depths.push_back(mm);
  if (depths.empty()) return std::nullopt;
  auto middle = depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2);
  std::nth_element(depths.begin(), middle, depths.end());
  const cv::Point c = (centre.tl() + centre.br()) / 2;
  return intrinsics.backproject(c.x, c.y, *middle * 1e-3);
}

double maxObjectHeight(const BowlGeometryParams& params) {
  return 1.25 * params.max_rim_diameter_m * params.max_height_to_diameter;
}

/// How far above the support a reading at range z must lie to be the object's: a depth step
/// off the support's surface.
double clearance(double z, const BowlGeometryParams& params) {
  const DepthStepRule off_support{.noise_steps = params.clearance_steps,
                                  .floor_m = params.min_clearance_m,
                                  .noise = params.noise};
  return off_support.threshold(z);
}

/// The plane the object stands on. Candidates: detected planes that face up in the image
/// (max_support_angle_from_image_up_deg), show beside and below the box and reach beyond it,
/// and hold the object's central point above them (within the clearance's noise, up to a
/// bowl's height). Of those, the one that shows most around the box's lower half: the surface
/// the bowl's foot meets, rather than the top of a box beside it or the floor far below.
std::optional<SupportPlane> chooseSupport(const PlaneDetection& planes, const cv::Rect& box,
                                          const Eigen::Vector3d& object_point,
                                          const BowlGeometryParams& params) {
  if (planes.labels.empty()) return std::nullopt;
  const auto shown =
      planePixelsBeside(planes.labels, supportWindow(box, planes.labels.size()), box);
  const double min_up_cos = std::cos(degToRad(params.max_support_angle_from_image_up_deg));
  const double noise = clearance(object_point.z(), params);
  auto heightOf = [&](const DetectedPlane& plane) {
    return plane.normal.dot(object_point) + plane.d;
  };
  std::vector<const DetectedPlane*> candidates;
  for (const auto& plane : planes.planes) {
    const auto it = shown.find(plane.id);
    if (it == shown.end() || it->second < params.min_support_samples) continue;
    if (-plane.normal.y() < min_up_cos || !reachesBeyond(plane, box)) continue;
    const double height = heightOf(plane);
    if (height > -noise && height <= maxObjectHeight(params)) candidates.push_back(&plane);
  }
  if (candidates.empty()) return std::nullopt;
  const auto* best = *std::max_element(
      candidates.begin(), candidates.end(),
      [&](const auto* a, const auto* b) { return shown.at(a->id) < shown.at(b->id); });
  return SupportPlane{best->normal, best->d, best->id};
}

double heightAbove(const SupportPlane& support, const Eigen::Vector3d& point) {
  return support.normal.dot(point) + support.d;
}

/// The box's readings in the camera frame and their heights above the support, on a grid of
/// every `step`-th pixel in each direction (z = 0: no reading), computed once for the object
/// and the dish.
struct BoxReadings {
  int step = 1;
  cv::Size grid;  ///< samples across and down
  std::vector<double> z;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> heights;

  std::size_t at(int u, int v) const { return static_cast<std::size_t>(v * grid.width + u); }
};

BoxReadings readBox(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                    const cv::Rect& box, const SupportPlane& support, int step) {
  BoxReadings readings{
      step, {(box.width + step - 1) / step, (box.height + step - 1) / step}, {}, {}, {}};
  const auto n = static_cast<std::size_t>(readings.grid.area());
  readings.z.assign(n, 0.0);
  readings.points.assign(n, Eigen::Vector3d::Zero());
  readings.heights.assign(n, 0.0);
  for (int v = 0; v < readings.grid.height; ++v) {
    const int y = box.y + v * step;
    const auto* row = depth_mm.ptr<std::uint16_t>(y);
    for (int u = 0; u < readings.grid.width; ++u) {
      const int x = box.x + u * step;
      if (row[x] == 0) continue;
      const std::size_t i = readings.at(u, v);
      readings.z[i] = row[x] * 1e-3;
      readings.points[i] = intrinsics.backproject(x, y, readings.z[i]);
      readings.heights[i] = heightAbove(support, readings.points[i]);
    }
  }
  return readings;
}

/// The connected surface standing on the support that holds the box's centre: readings above
/// the support's clearance, joined across neighbouring pixels without a depth step; of the
/// components reaching the central half of the box, the largest.
std::vector<Eigen::Vector3d> objectOnSupport(const BoxReadings& readings,
                                             const BowlGeometryParams& params) {
  const cv::Size grid = readings.grid;
  const double max_height = maxObjectHeight(params);
  cv::Mat standing(grid, CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < grid.height; ++v) {
    for (int u = 0; u < grid.width; ++u) {
      const std::size_t i = readings.at(u, v);
      const double z = readings.z[i], h = readings.heights[i];
      if (z > 0 && h > clearance(z, params) && h < max_height) standing.at<std::uint8_t>(v, u) = 1;
    }
  }
  // Samples `step` pixels apart on one smooth surface differ up to `step` times as much as
  // neighbouring pixels do.
  const DepthStepRule surface_break{.noise_steps = params.max_step_steps * readings.step,
                                    .floor_m = params.max_step_floor_m * readings.step,
                                    .noise = params.noise};
  auto joined = [&](int u0, int v0, int u1, int v1) {
    return !surface_break.isStep(readings.z[readings.at(u0, v0)], readings.z[readings.at(u1, v1)]);
  };
  cv::Mat component(grid, CV_32SC1, cv::Scalar(0));
  const cv::Rect centre(grid.width / 4, grid.height / 4, grid.width / 2, grid.height / 2);
  int best_label = 0, best_size = 0, label = 0;
  std::vector<cv::Point> stack;
  for (int v = 0; v < grid.height; ++v) {
    for (int u = 0; u < grid.width; ++u) {
      if (!standing.at<std::uint8_t>(v, u) || component.at<int>(v, u) != 0) continue;
      ++label;
      int size = 0;
      bool central = false;
      stack.assign(1, {u, v});
      component.at<int>(v, u) = label;
      while (!stack.empty()) {
        const cv::Point p = stack.back();
        stack.pop_back();
        ++size;
        central = central || centre.contains(p);
        const cv::Point neighbours[4] = {
            {p.x - 1, p.y}, {p.x + 1, p.y}, {p.x, p.y - 1}, {p.x, p.y + 1}};
        for (const cv::Point& q : neighbours) {
          if (q.x < 0 || q.y < 0 || q.x >= grid.width || q.y >= grid.height) continue;
          if (!standing.at<std::uint8_t>(q) || component.at<int>(q) != 0) continue;
          if (!joined(p.x, p.y, q.x, q.y)) continue;
          component.at<int>(q) = label;
          stack.push_back(q);
        }
      }
      if (central && size > best_size) {
        best_size = size;
        best_label = label;
      }
    }
  }
  std::vector<Eigen::Vector3d> points;
  if (best_label == 0) return points;
  points.reserve(static_cast<std::size_t>(best_size));
  for (int v = 0; v < grid.height; ++v)
    for (int u = 0; u < grid.width; ++u)
      if (component.at<int>(v, u) == best_label)
        points.push_back(readings.points[readings.at(u, v)]);
  return points;
}

/// Heights above the support, and positions along the horizontal axis across the line of
/// sight (looking straight down at the support, any horizontal axis: the camera's x) and along
/// the horizontal axis perpendicular to it.
Profile profileOf(const std::vector<Eigen::Vector3d>& points, const SupportPlane& support) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Vector3d across = support.normal.cross(centroid);
  if (across.norm() < 1e-3 * centroid.norm()) {
    across = Eigen::Vector3d::UnitX() - support.normal.x() * support.normal;
  }
  across.normalize();
  const Eigen::Vector3d along = across.cross(support.normal);
  Profile profile;
  profile.across_axis = across;
  profile.along_axis = along;
  profile.heights.reserve(points.size());
  profile.across.reserve(points.size());
  profile.along.reserve(points.size());
  for (const auto& p : points) {
    profile.heights.push_back(heightAbove(support, p));
    profile.across.push_back(across.dot(p));
    profile.along.push_back(along.dot(p));
  }
  return profile;
}

/// Spread across the line of sight (3rd to 97th percentile) of the points whose height lies
/// in [low, high]; 0 with too few points.
double bandWidth(const Profile& profile, double low, double high) {
  std::vector<double> across;
  for (std::size_t i = 0; i < profile.heights.size(); ++i)
    if (profile.heights[i] >= low && profile.heights[i] <= high)
      across.push_back(profile.across[i]);
  if (across.size() < static_cast<std::size_t>(kMinBandPoints)) return 0;
  const double lo = quantile(across, 0.03);
  return quantile(across, 0.97) - lo;
}

/// Midpoint of the 3rd and 97th percentiles of values[i] over the indices in `band`.
double bandMiddle(const std::vector<double>& values, const std::vector<std::size_t>& band) {
  std::vector<double> selected;
  selected.reserve(band.size());
  for (const std::size_t i : band) selected.push_back(values[i]);
  const double lo = quantile(selected, 0.03);
  return 0.5 * (lo + quantile(selected, 0.97));
}

/// How far the middle of the object lies below its top, as a share of its visible height: the
/// median height of the box's readings within dish_radius_fraction x the rim of the axis (the
/// middle of the rim band, horizontally) against the top. Readings below the object's
/// clearance count: looking into a bowl, the middle is its inside bottom, nearly at the
/// support's height; from the side, the foot of its front wall (a bowl narrows downwards). A
/// tin's lid, a box's top, a ball's or an upside-down bowl's crown are the top itself. -1 when
/// no reading lies that near the axis (a tin's wall from the side).
double dishDepth(const Profile& profile, const std::vector<Eigen::Vector3d>& box_readings,
                 const SupportPlane& support, double bottom, double top, double band, double rim,
                 const BowlGeometryParams& params) {
  std::vector<std::size_t> rim_band;
  for (std::size_t i = 0; i < profile.heights.size(); ++i)
    if (profile.heights[i] >= top - band) rim_band.push_back(i);
  if (rim_band.size() < static_cast<std::size_t>(kMinBandPoints) || top <= bottom) return -1;
  const double axis_across = bandMiddle(profile.across, rim_band);
  const double axis_along = bandMiddle(profile.along, rim_band);
  const double radius = params.dish_radius_fraction * rim;
  std::vector<double> middle;
  for (const auto& p : box_readings) {
    const double a = profile.across_axis.dot(p) - axis_across;
    const double b = profile.along_axis.dot(p) - axis_along;
    if (a * a + b * b <= radius * radius) middle.push_back(heightAbove(support, p));
  }
  if (middle.size() < static_cast<std::size_t>(kMinBandPoints)) return -1;
  return (top - quantile(middle, 0.5)) / (top - bottom);
}

/// The box's readings that may belong to an object on the support: from just under it (its
/// noise) up to a bowl's height.
std::vector<Eigen::Vector3d> readingsOnSupport(const BoxReadings& readings,
                                               const BowlGeometryParams& params) {
  std::vector<Eigen::Vector3d> on_support;
  const double max_height = maxObjectHeight(params);
  for (std::size_t i = 0; i < readings.z.size(); ++i) {
    const double z = readings.z[i], h = readings.heights[i];
    if (z > 0 && h > -clearance(z, params) && h < max_height)
      on_support.push_back(readings.points[i]);
  }
  return on_support;
}

/// Measures the profile into `result.geometry` and judges it.
void judgeProfile(const Profile& profile, const std::vector<Eigen::Vector3d>& box_readings,
                  const SupportPlane& support, double range_m, const BowlGeometryParams& params,
                  BowlGeometryResult& result) {
  std::vector<double> heights = profile.heights;
  const double bottom = quantile(heights, 0.02);
  const double top = quantile(heights, 0.98);
  const double band = params.band_fraction * (top - bottom);
  BowlGeometry& geometry = result.geometry;
  geometry.height_m = top - bottom;
  geometry.top_m = top;
  geometry.rim_diameter_m = bandWidth(profile, top - band, top);
  const double foot = bandWidth(profile, bottom, bottom + band);
  geometry.rim_to_foot_width = foot > 0 ? geometry.rim_diameter_m / foot : 0;
  geometry.dish_depth =
      dishDepth(profile, box_readings, support, bottom, top, band, geometry.rim_diameter_m, params);
  const double rim = std::max(1e-6, geometry.rim_diameter_m);
  const bool wider_at_rim = foot > 0 && geometry.rim_to_foot_width >= params.min_rim_to_foot_width;
  if (top < params.min_top_steps * params.noise.depthStep(range_m))
    result.rejection = BowlGeometryRejection::kTooCoarse;
  else if (geometry.rim_diameter_m < params.min_rim_diameter_m)
    result.rejection = BowlGeometryRejection::kRimTooSmall;
  else if (geometry.rim_diameter_m > params.max_rim_diameter_m)
    result.rejection = BowlGeometryRejection::kRimTooLarge;
  else if (top < params.min_height_to_diameter * rim ||
           geometry.height_m > params.max_height_to_diameter * rim)
    result.rejection = BowlGeometryRejection::kHeight;
  else if (!wider_at_rim && geometry.dish_depth < params.min_dish_depth)
    result.rejection = BowlGeometryRejection::kNotBowlShaped;
}

}  // namespace

std::string toString(BowlGeometryRejection reason) {
  switch (reason) {
    case BowlGeometryRejection::kNoSupport:
      return "no supporting plane under the box";
    case BowlGeometryRejection::kNoObject:
      return "nothing stands on the support at the box's centre";
    case BowlGeometryRejection::kTooCoarse:
      return "too far for the sensor's depth steps to show its shape";
    case BowlGeometryRejection::kRimTooSmall:
      return "rim narrower than a bowl's (or seen in part)";
    case BowlGeometryRejection::kRimTooLarge:
      return "rim wider than a bowl's";
    case BowlGeometryRejection::kHeight:
      return "height out of proportion to the rim";
    case BowlGeometryRejection::kNotBowlShaped:
      return "neither wider at the rim than at the foot nor dished";
  }
  return "unknown";
}

bool isInconclusive(BowlGeometryRejection reason) {
  return reason == BowlGeometryRejection::kNoSupport ||
         reason == BowlGeometryRejection::kNoObject ||
         reason == BowlGeometryRejection::kTooCoarse ||
         reason == BowlGeometryRejection::kRimTooSmall;
}

BowlGeometryResult measureBowlGeometry(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                       const cv::Rect& box, const PlaneDetection& planes,
                                       const BowlGeometryParams& params) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  BowlGeometryResult result;
  const cv::Rect clipped = box & cv::Rect(0, 0, depth_mm.cols, depth_mm.rows);
  const auto object_point = clipped.width >= 2 && clipped.height >= 2
                                ? centralPoint(depth_mm, intrinsics, clipped)
                                : std::nullopt;
  if (!object_point) {
    result.rejection = BowlGeometryRejection::kNoObject;
    return result;
  }
  const auto support = chooseSupport(planes, clipped, *object_point, params);
  if (!support) {
    result.rejection = BowlGeometryRejection::kNoSupport;
    return result;
  }
  result.geometry.support_normal = support->normal;
  result.geometry.support_d = support->d;
  result.geometry.support_plane_id = support->id;
  const BoxReadings readings =
      readBox(depth_mm, intrinsics, clipped, *support, sampleStep(clipped, params.max_box_samples));
  const auto points = objectOnSupport(readings, params);
  if (points.size() < static_cast<std::size_t>(4 * kMinBandPoints)) {
    result.rejection = BowlGeometryRejection::kNoObject;
    return result;
  }
  judgeProfile(profileOf(points, *support), readingsOnSupport(readings, params), *support,
               object_point->z(), params, result);
  return result;
}

}  // namespace shapesense
