#include "shapesense/core/boxes/box_estimation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

namespace shapesense {
namespace {

// Consistency constant turning a MAD into a standard deviation for Gaussian data.
constexpr double kMadToSigma = 1.4826;
// Even with the near-limit rule disabled, a box must stay in front of the camera.
constexpr double kMinPositiveDepthM = 1e-3;
// Longest pixel ray (z = 1) of a camera: 88.2 degrees off the optical axis, past any pinhole
// lens (a 160-degree field of view with the principal point at an image corner reaches 16).
// It bounds mode 1's ranges, hence its histogram, to 32 times the depths: 2 million bins at most.
constexpr double kMaxRayNorm = 32.0;

BoxEstimationFailure fail(BoxEstimationError code, std::string message) {
  return BoxEstimationFailure{code, std::move(message)};
}

// The readings counted in 1 mm bins, the depth image's own resolution: Z readings (modes 2 and
// 3) fall exactly on bins, ranges (mode 1) are rounded by at most 0.5 mm, far below the
// sensor's noise. Every statistic of the robust window is then a walk over at most a few
// thousand bins instead of a selection over every reading, and the ROI is read once: an ROI
// covering half the image costs one pass over its pixels.
class MillimetreHistogram {
 public:
  /// Bins for readings in [min_mm, max_mm].
  MillimetreHistogram(int min_mm, int max_mm)
      : first_bin_reading_(min_mm), counts_(static_cast<std::size_t>(max_mm - min_mm) + 1, 0) {}

  void add(int mm) { ++counts_[static_cast<std::size_t>(mm - first_bin_reading_)]; }
  /// Call once after the last add, before any query.
  void finish() {
    prefix_.assign(counts_.size() + 1, 0);
    for (std::size_t b = 0; b < counts_.size(); ++b) prefix_[b + 1] = prefix_[b] + counts_[b];
  }

  double metres(int bin) const { return 0.001 * (first_bin_reading_ + bin); }
  int lastBin() const { return static_cast<int>(counts_.size()) - 1; }
  int countAt(int bin) const { return counts_[static_cast<std::size_t>(bin)]; }
  /// Readings in bins [lo, hi].
  int count(int lo, int hi) const {
    return prefix_[static_cast<std::size_t>(hi) + 1] - prefix_[static_cast<std::size_t>(lo)];
  }

  /// Bin of the reading of 0-based `rank` in sorted order among bins [lo, hi].
  int binOfRank(int lo, int hi, int rank) const {
    // First bin b in [lo, hi) whose cumulative count passes the rank.
    const auto first = prefix_.begin() + lo + 1;
    const auto last = prefix_.begin() + hi + 1;
    const auto it = std::upper_bound(first, last, prefix_[static_cast<std::size_t>(lo)] + rank);
    return it == last ? hi : static_cast<int>(it - prefix_.begin()) - 1;
  }

  /// Lower median, over the readings in bins [lo, hi], of their distance in bins to `center`.
  int medianDistance(int lo, int hi, int center) const {
    const int rank = (count(lo, hi) - 1) / 2;
    int seen = 0;
    for (int k = 0;; ++k) {
      if (center - k >= lo) seen += countAt(center - k);
      if (k > 0 && center + k <= hi) seen += countAt(center + k);
      if (seen > rank || (center - k <= lo && center + k >= hi)) return k;
    }
  }

 private:
  int first_bin_reading_;  // the reading (mm) counted in bin 0
  std::vector<int> counts_;
  std::vector<int> prefix_;
};

// The robust window and its statistics (see RoiDepthStatistics) over a finished histogram.
RoiDepthStatistics windowStatistics(const MillimetreHistogram& histogram,
                                    const BoxEstimationParams& params) {
  RoiDepthStatistics stats;
  // The kept set is always a window of bins [lo, hi]: it starts as all readings.
  int lo = 0;
  int hi = histogram.lastBin();
  int kept = histogram.count(lo, hi);
  stats.valid_pixels = kept;
  int center_bin = 0;
  double sigma = 0.0;
  const int iterations = std::max(0, params.refine_iterations);
  for (int it = 0; it <= iterations; ++it) {
    // Centre and spread from the current kept set, window applied to all readings: a window
    // that once excluded a reading may take it back after re-centring.
    center_bin = histogram.binOfRank(lo, hi, (kept - 1) / 2);
    const double center = histogram.metres(center_bin);
    sigma = kMadToSigma * 0.001 * histogram.medianDistance(lo, hi, center_bin);
    const double floor_sigma =
        std::max(params.min_sigma_m, params.min_sigma_steps * params.noise.depthStep(center));
    const double window = params.inlier_sigmas * std::max(sigma, floor_sigma);
    // A reading exactly on the window's edge is kept (hence the rounding slack). A window wider
    // than the histogram keeps everything; capping it first keeps the int conversion defined.
    const double window_bins = std::floor(window / 0.001 + 1e-6);
    const int half_bins = !(window_bins > 0.0)                ? 0
                          : window_bins < histogram.lastBin() ? static_cast<int>(window_bins)
                                                              : histogram.lastBin();
    const int next_lo = std::max(0, center_bin - half_bins);
    const int next_hi = std::min(histogram.lastBin(), center_bin + half_bins);
    // The centre is one of the readings, so the window is never empty.
    const int next_kept = histogram.count(next_lo, next_hi);
    const bool converged = next_kept == kept;
    lo = next_lo;
    hi = next_hi;
    kept = next_kept;
    if (converged && it > 0) break;
  }

  // Moments in bins relative to the centre (small numbers, no cancellation).
  double sum = 0.0;
  double sq = 0.0;
  for (int b = lo; b <= hi; ++b) {
    const double offset = b - center_bin;
    sum += histogram.countAt(b) * offset;
    sq += histogram.countAt(b) * offset * offset;
  }
  const auto n = static_cast<double>(kept);
  const double mean_offset = sum / n;
  const double mean = histogram.metres(center_bin) + 0.001 * mean_offset;
  const double stddev = 0.001 * std::sqrt(std::max(0.0, sq / n - mean_offset * mean_offset));

  stats.used_pixels = kept;
  stats.mean_m = mean;
  stats.std_m = stddev;
  stats.median_m = histogram.metres(center_bin);
  stats.mad_sigma_m = sigma;
  stats.min_m = histogram.metres(histogram.binOfRank(lo, hi, 0));
  stats.max_m = histogram.metres(histogram.binOfRank(lo, hi, kept - 1));
  stats.near_m = mean - params.std_scale * stddev;
  stats.far_m = mean + params.std_scale * stddev;
  if (params.clamp_to_kept_range) {
    // Past the (trimmed) extremes of the kept readings there is no evidence of the object: a
    // skewed set (object plus some table behind it) would otherwise push the opposite face out.
    const double trim = std::clamp(params.range_trim, 0.0, 0.5);
    const double last = static_cast<double>(kept - 1);
    const int lo_rank = static_cast<int>(std::floor(trim * last));
    const int hi_rank = static_cast<int>(std::ceil((1.0 - trim) * last));
    stats.near_m = std::max(stats.near_m, histogram.metres(histogram.binOfRank(lo, hi, lo_rank)));
    stats.far_m = std::min(stats.far_m, histogram.metres(histogram.binOfRank(lo, hi, hi_rank)));
  }
  return stats;
}

int roundToMillimetres(double metres) { return static_cast<int>(std::lround(metres * 1000.0)); }

// Widest interval [lo, hi] (one axis, metres) of an axis-aligned box spanning depths [z1, z2]
// whose projection stays within the normalised ROI interval [a, b] (a < b). Along one axis the
// projection x/z of a point with x > 0 is smallest at the back, with x < 0 at the front, so a
// bound on the far side of the principal point binds the back face and one on the near side the
// front face (the seed's T1/T2 construction, without its axis flipping).
struct AxisExtent {
  double lo;
  double hi;
  bool collapsed;
};
AxisExtent containedExtent(double a, double b, double z1, double z2) {
  const double lo = a * (a > 0.0 ? z2 : z1);
  const double hi = b * (b < 0.0 ? z2 : z1);
  if (lo > hi) {
    // No box this deep fits: the seed collapses the coordinate to the mean of T1 and T2.
    const double mid = 0.5 * (lo + hi);
    return {mid, mid, true};
  }
  return {lo, hi, false};
}

BoxCorners axisAlignedCorners(double x_left, double x_right, double y_top, double y_bottom,
                              double z_front, double z_back) {
  return {Eigen::Vector3d(x_left, y_top, z_front),     Eigen::Vector3d(x_right, y_top, z_front),
          Eigen::Vector3d(x_right, y_bottom, z_front), Eigen::Vector3d(x_left, y_bottom, z_front),
          Eigen::Vector3d(x_left, y_top, z_back),      Eigen::Vector3d(x_right, y_top, z_back),
          Eigen::Vector3d(x_right, y_bottom, z_back),  Eigen::Vector3d(x_left, y_bottom, z_back)};
}

// Faces as corner cycles, and the face opposite each (for degenerate-face fallbacks).
constexpr std::array<std::array<int, 4>, 6> kFaces{{{0, 1, 2, 3},    // front
                                                    {4, 5, 6, 7},    // back
                                                    {0, 1, 5, 4},    // top
                                                    {3, 2, 6, 7},    // bottom
                                                    {0, 3, 7, 4},    // left
                                                    {1, 2, 6, 5}}};  // right
constexpr std::array<int, 6> kOppositeFace{1, 0, 3, 2, 5, 4};

Eigen::Vector3d faceCentroid(const BoxCorners& c, int f) {
  const auto& q = kFaces[static_cast<std::size_t>(f)];
  return 0.25 * (c[q[0]] + c[q[1]] + c[q[2]] + c[q[3]]);
}

Eigen::Vector3d boxCentroid(const BoxCorners& c) {
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  for (const auto& p : c) s += p;
  return s / 8.0;
}

double boxScale(const BoxCorners& c) {
  double s = 0.0;
  for (const auto& p : c) s = std::max(s, (p - c[0]).norm());
  return s;
}

// Liang-Barsky clip of segment p0-p1 to [xmin, xmax] x [ymin, ymax]; false if nothing is left.
bool clipSegment(Eigen::Vector2d& p0, Eigen::Vector2d& p1, double xmin, double xmax, double ymin,
                 double ymax) {
  double t0 = 0.0;
  double t1 = 1.0;
  const Eigen::Vector2d d = p1 - p0;
  const double p[4] = {-d.x(), d.x(), -d.y(), d.y()};
  const double q[4] = {p0.x() - xmin, xmax - p0.x(), p0.y() - ymin, ymax - p0.y()};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0.0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
  }
  const Eigen::Vector2d start = p0;
  p0 = start + t0 * d;
  p1 = start + t1 * d;
  return true;
}

}  // namespace

RoiDepthStatistics robustDepthStatistics(const std::vector<double>& values,
                                         const BoxEstimationParams& params) {
  if (values.empty()) return {};
  const auto [min_it, max_it] = std::minmax_element(values.begin(), values.end());
  MillimetreHistogram histogram(roundToMillimetres(*min_it), roundToMillimetres(*max_it));
  for (double x : values) histogram.add(roundToMillimetres(x));
  histogram.finish();
  return windowStatistics(histogram, params);
}

namespace {

// The ROI's pixel bounds, inclusive.
struct RoiBounds {
  int u0, u1, v0, v1;
};

// Why a request's image, intrinsics or ROI cannot be estimated, if they cannot.
std::optional<BoxEstimationFailure> invalidRoiRequest(const cv::Mat& depth_mm,
                                                      const CameraIntrinsics& intrinsics,
                                                      const RoiBounds& roi) {
  using Err = BoxEstimationError;
  if (depth_mm.empty()) {
    return fail(Err::kEmptyRoi, "the depth image has no pixels, so the ROI is empty");
  }
  if (depth_mm.type() != CV_16UC1) {
    return fail(Err::kInvalidArgument, "depth image must be CV_16UC1 millimetres");
  }
  if (!(intrinsics.fx > 0.0) || !(intrinsics.fy > 0.0) || !std::isfinite(intrinsics.fx) ||
      !std::isfinite(intrinsics.fy) || !std::isfinite(intrinsics.cx) ||
      !std::isfinite(intrinsics.cy)) {
    return fail(Err::kInvalidArgument, "intrinsics need positive finite focal lengths");
  }
  const auto [u0, u1, v0, v1] = roi;
  if (u0 < 0 || v0 < 0 || u1 >= depth_mm.cols || v1 >= depth_mm.rows) {
    return fail(Err::kRoiOutsideImage, "ROI (" + std::to_string(u0) + "," + std::to_string(v0) +
                                           ")-(" + std::to_string(u1) + "," + std::to_string(v1) +
                                           ") is not inside the " + std::to_string(depth_mm.cols) +
                                           "x" + std::to_string(depth_mm.rows) + " image");
  }
  return std::nullopt;
}

RoiBounds roiBounds(cv::Point p1, cv::Point p2) {
  return {std::min(p1.x, p2.x), std::max(p1.x, p2.x), std::min(p1.y, p2.y), std::max(p1.y, p2.y)};
}

// Why estimateBox cannot estimate a request, if it cannot: a mode it does not handle, or an
// unsound image, intrinsics or ROI.
std::optional<BoxEstimationFailure> invalidRequest(const cv::Mat& depth_mm,
                                                   const CameraIntrinsics& intrinsics,
                                                   const RoiBounds& roi, BoxMode mode) {
  if (mode == BoxMode::kSegments) {
    return fail(BoxEstimationError::kInvalidArgument,
                "box mode 4 (segments) needs the frame's segmentation and planes: use "
                "boxFromSegments");
  }
  if (mode != BoxMode::kFrustumAligned && mode != BoxMode::kAxisAlignedContained &&
      mode != BoxMode::kAxisAlignedFrontFace) {
    return fail(BoxEstimationError::kInvalidArgument,
                "unknown box estimation mode " + std::to_string(static_cast<int>(mode)));
  }
  return invalidRoiRequest(depth_mm, intrinsics, roi);
}

// The robust depth statistics of the ROI's readings: ranges from the optical centre in mode 1,
// Z in modes 2 and 3 (the design). `max_norm` is the largest |ray| of the ROI. Kept out of line:
// inlined into estimateBox, GCC 12 compiles the ROI loops about 20% slower on small ROIs
// (BM_EstimateBoxInProcess).
[[gnu::noinline]] std::variant<RoiDepthStatistics, BoxEstimationFailure> roiStatistics(
    const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics, const RoiBounds& roi,
    double max_norm, bool use_range, const BoxEstimationParams& params) {
  // Plain copies, not a structured binding: clang 14 (the fuzz build) cannot capture those.
  const int u0 = roi.u0, u1 = roi.u1, v0 = roi.v0, v1 = roi.v1;
  const int max_valid = static_cast<int>(
      std::clamp(std::floor(params.max_valid_depth_m * 1000.0 + 1e-6), 0.0, 65535.0));
  int min_mm = 65536;
  int max_mm = 0;
  for (int v = v0; v <= v1; ++v) {
    const auto* row = depth_mm.ptr<std::uint16_t>(v);
    for (int u = u0; u <= u1; ++u) {
      const int mm = row[u];
      if (mm == 0 || mm > max_valid) continue;
      min_mm = std::min(min_mm, mm);
      max_mm = std::max(max_mm, mm);
    }
  }
  if (max_mm == 0) {
    return fail(BoxEstimationError::kNoValidDepth,
                "no depth reading in the ROI (all pixels are 0 or too far)");
  }
  const auto countRoi = [&](MillimetreHistogram& histogram, auto&& to_bin_mm) {
    for (int v = v0; v <= v1; ++v) {
      const auto* row = depth_mm.ptr<std::uint16_t>(v);
      for (int u = u0; u <= u1; ++u) {
        const int mm = row[u];
        if (mm != 0 && mm <= max_valid) histogram.add(to_bin_mm(mm, u, v));
      }
    }
    histogram.finish();
    return windowStatistics(histogram, params);
  };
  if (!use_range) {
    MillimetreHistogram histogram(min_mm, max_mm);
    return countRoi(histogram, [](int mm, int, int) { return mm; });
  }
  // Range = Z * |ray|, with 1 <= |ray| <= max_norm.
  MillimetreHistogram histogram(min_mm, static_cast<int>(std::ceil(max_mm * max_norm)) + 1);
  std::vector<double> column_sq(static_cast<std::size_t>(u1 - u0 + 1));
  for (int u = u0; u <= u1; ++u) {
    const double x = (u - intrinsics.cx) / intrinsics.fx;
    column_sq[static_cast<std::size_t>(u - u0)] = x * x;
  }
  int row_v = -1;
  double row_sq = 0.0;
  return countRoi(histogram, [&](int mm, int u, int v) {
    if (v != row_v) {
      const double y = (v - intrinsics.cy) / intrinsics.fy;
      row_sq = 1.0 + y * y;
      row_v = v;
    }
    return static_cast<int>(
        std::lround(mm * std::sqrt(row_sq + column_sq[static_cast<std::size_t>(u - u0)])));
  });
}

// The ROI's frustum through the outer edges of its border pixels, in normalised coordinates.
struct NormalisedFrustum {
  double xl, xr, yt, yb;
};

// Mode 1: edge rays (z = 1) in corner order, and the central axis through the ROI centre. The
// front face is the plane axis . p = near; its corners are where the edge rays cross it.
void frustumAlignedBox(const NormalisedFrustum& f, double min_z, double& near, double& far,
                       BoxEstimate& out) {
  const auto [xl, xr, yt, yb] = f;
  const std::array<Eigen::Vector3d, 4> rays{
      Eigen::Vector3d(xl, yt, 1.0), Eigen::Vector3d(xr, yt, 1.0), Eigen::Vector3d(xr, yb, 1.0),
      Eigen::Vector3d(xl, yb, 1.0)};
  const Eigen::Vector3d axis = Eigen::Vector3d(0.5 * (xl + xr), 0.5 * (yt + yb), 1.0).normalized();
  // A corner on ray r at plane distance d has z = d / (axis . r): the nearest front corner
  // is the one whose ray is closest to the axis. Move the plane (and the back face with it)
  // back until that corner reaches the near limit.
  double max_cos = 0.0;
  for (const auto& r : rays) max_cos = std::max(max_cos, axis.dot(r));
  const double min_near = min_z * max_cos;
  if (near < min_near) {
    out.stats.moved_back_m = min_near - near;
    far += min_near - near;
    near = min_near;
  }
  for (int i = 0; i < 4; ++i) {
    const auto& r = rays[static_cast<std::size_t>(i)];
    out.corners[static_cast<std::size_t>(i)] = r * (near / axis.dot(r));
    out.corners[static_cast<std::size_t>(i + 4)] =
        out.corners[static_cast<std::size_t>(i)] + (far - near) * axis;
  }
}

// Modes 2 and 3: a box aligned with the camera axes, its front face at the near depth.
void axisAlignedBox(const NormalisedFrustum& f, double min_z, BoxMode mode, double& near,
                    double& far, BoxEstimate& out) {
  const auto [xl, xr, yt, yb] = f;
  if (near < min_z) {
    out.stats.moved_back_m = min_z - near;
    far += min_z - near;
    near = min_z;
  }
  if (mode == BoxMode::kAxisAlignedFrontFace) {
    out.corners = axisAlignedCorners(xl * near, xr * near, yt * near, yb * near, near, far);
  } else {
    const AxisExtent x = containedExtent(xl, xr, near, far);
    const AxisExtent y = containedExtent(yt, yb, near, far);
    out.collapsed_x = x.collapsed;
    out.collapsed_y = y.collapsed;
    out.corners = axisAlignedCorners(x.lo, x.hi, y.lo, y.hi, near, far);
  }
}

}  // namespace

std::variant<BoxEstimate, BoxEstimationFailure> estimateBox(const cv::Mat& depth_mm,
                                                            const CameraIntrinsics& intrinsics,
                                                            cv::Point p1, cv::Point p2,
                                                            BoxMode mode,
                                                            const BoxEstimationParams& params) {
  const RoiBounds roi = roiBounds(p1, p2);
  if (auto failure = invalidRequest(depth_mm, intrinsics, roi, mode)) return *failure;
  const auto [u0, u1, v0, v1] = roi;
  // |ray| is largest at one of the ROI's corners.
  const auto ray_norm = [&](int u, int v) { return intrinsics.ray(u, v).norm(); };
  const double max_norm =
      std::max({ray_norm(u0, v0), ray_norm(u1, v0), ray_norm(u0, v1), ray_norm(u1, v1)});
  if (!(max_norm <= kMaxRayNorm)) {
    return fail(BoxEstimationError::kInvalidArgument,
                "the intrinsics (fx " + std::to_string(intrinsics.fx) + ", fy " +
                    std::to_string(intrinsics.fy) + ", cx " + std::to_string(intrinsics.cx) +
                    ", cy " + std::to_string(intrinsics.cy) +
                    ") put the ROI's corners more than 88 degrees off the optical axis: no "
                    "camera sees that");
  }
  const bool use_range = mode == BoxMode::kFrustumAligned;
  auto stats = roiStatistics(depth_mm, intrinsics, roi, max_norm, use_range, params);
  if (auto* failure = std::get_if<BoxEstimationFailure>(&stats)) return *failure;
  BoxEstimate out;
  out.mode = mode;
  out.stats = std::get<RoiDepthStatistics>(stats);
  out.stats.range_from_origin = use_range;
  double near = out.stats.near_m;
  double far = out.stats.far_m;
  const double m = params.roi_pixel_margin;
  const NormalisedFrustum frustum{
      (u0 - m - intrinsics.cx) / intrinsics.fx, (u1 + m - intrinsics.cx) / intrinsics.fx,
      (v0 - m - intrinsics.cy) / intrinsics.fy, (v1 + m - intrinsics.cy) / intrinsics.fy};
  const double min_z = std::max(params.min_front_depth_m, kMinPositiveDepthM);
  if (mode == BoxMode::kFrustumAligned) {
    frustumAlignedBox(frustum, min_z, near, far, out);
  } else {
    axisAlignedBox(frustum, min_z, mode, near, far, out);
  }
  out.stats.near_m = near;
  out.stats.far_m = far;
  return out;
}

std::optional<BoxEstimationFailure> checkRoiRequest(const cv::Mat& depth_mm,
                                                    const CameraIntrinsics& intrinsics,
                                                    cv::Point p1, cv::Point p2) {
  return invalidRoiRequest(depth_mm, intrinsics, roiBounds(p1, p2));
}

double boxVolume(const BoxCorners& corners) {
  // Sum of the tetrahedra from the centroid over the faces' triangles (the box is convex).
  const Eigen::Vector3d c = boxCentroid(corners);
  double volume = 0.0;
  for (const auto& q : kFaces) {
    const Eigen::Vector3d a = corners[q[0]] - c;
    const Eigen::Vector3d b = corners[q[1]] - c;
    const Eigen::Vector3d d = corners[q[2]] - c;
    const Eigen::Vector3d e = corners[q[3]] - c;
    volume += std::abs(a.dot(b.cross(d))) + std::abs(a.dot(d.cross(e)));
  }
  return volume / 6.0;
}

bool boxContains(const BoxCorners& corners, const Eigen::Vector3d& point, double tolerance_m) {
  const Eigen::Vector3d c = boxCentroid(corners);
  const double scale = boxScale(corners);
  const double eps = 1e-12 * std::max(scale * scale, 1e-12);
  for (int f = 0; f < 6; ++f) {
    const auto& q = kFaces[static_cast<std::size_t>(f)];
    const Eigen::Vector3d fc = faceCentroid(corners, f);
    Eigen::Vector3d n = (corners[q[2]] - corners[q[0]]).cross(corners[q[3]] - corners[q[1]]);
    if (n.norm() <= eps) {
      // A collapsed face (mode 2 collapse) has no normal of its own; the direction from the
      // opposite face still bounds the box on this side.
      n = fc - faceCentroid(corners, kOppositeFace[static_cast<std::size_t>(f)]);
      if (n.norm() <= 1e-12 * std::max(scale, 1e-12)) continue;
    }
    n.normalize();
    if (n.dot(fc - c) < 0.0) n = -n;  // outward
    if (n.dot(point - fc) > tolerance_m) return false;
  }
  return true;
}

void drawBox(cv::Mat& bgr, const CameraIntrinsics& intrinsics, const BoxCorners& corners,
             cv::Scalar color, int thickness) {
  if (bgr.empty()) return;
  // Points behind (or nearly at) the camera have no projection: cut edges at z = 1 cm.
  constexpr double kClipZ = 0.01;
  constexpr int kShift = 4;  // sub-pixel bits for cv::line
  constexpr double kScale = 1 << kShift;
  for (std::size_t e = 0; e < kBoxEdges.size(); ++e) {
    Eigen::Vector3d a = corners[static_cast<std::size_t>(kBoxEdges[e][0])];
    Eigen::Vector3d b = corners[static_cast<std::size_t>(kBoxEdges[e][1])];
    if (!a.allFinite() || !b.allFinite()) continue;
    if (a.z() < kClipZ && b.z() < kClipZ) continue;
    if (a.z() < kClipZ) a = a + (b - a) * ((kClipZ - a.z()) / (b.z() - a.z()));
    if (b.z() < kClipZ) b = b + (a - b) * ((kClipZ - b.z()) / (a.z() - b.z()));
    Eigen::Vector2d pa = intrinsics.project(a);
    Eigen::Vector2d pb = intrinsics.project(b);
    // Clip to just beyond the image so the int pixel coordinates cannot overflow.
    if (!clipSegment(pa, pb, -2.0, bgr.cols + 1.0, -2.0, bgr.rows + 1.0)) continue;
    const int t = e < 4 ? thickness + 1 : thickness;  // front face thicker: shows orientation
    cv::line(bgr, cv::Point(cvRound(pa.x() * kScale), cvRound(pa.y() * kScale)),
             cv::Point(cvRound(pb.x() * kScale), cvRound(pb.y() * kScale)), color, std::max(1, t),
             cv::LINE_AA, kShift);
  }
}

const char* toString(BoxMode mode) {
  switch (mode) {
    case BoxMode::kFrustumAligned:
      return "FrustumAligned";
    case BoxMode::kAxisAlignedContained:
      return "AxisAlignedContained";
    case BoxMode::kAxisAlignedFrontFace:
      return "AxisAlignedFrontFace";
    case BoxMode::kSegments:
      return "Segments";
  }
  return "Unknown";
}

const char* toString(BoxEstimationError code) {
  switch (code) {
    case BoxEstimationError::kRoiOutsideImage:
      return "RoiOutsideImage";
    case BoxEstimationError::kEmptyRoi:
      return "EmptyRoi";
    case BoxEstimationError::kNoValidDepth:
      return "NoValidDepth";
    case BoxEstimationError::kInvalidArgument:
      return "InvalidArgument";
  }
  return "Unknown";
}

}  // namespace shapesense
