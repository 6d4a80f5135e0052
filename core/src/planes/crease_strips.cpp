#include "planes/crease_strips.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <utility>

#include "shapesense/core/geometry/plane_fitting.h"
#include "shapesense/core/geometry/two_plane_fit.h"
#include "shapesense/core/geometry/units.h"

namespace shapesense::labeling {
namespace {

// Readings farther off the plane than this many tolerances lie beyond a depth step (an
// occluder, the background) and say nothing about a crease.
constexpr float kReachTolerances = 3.0f;
// A region's noise is never taken below this many depth steps: quantisation alone gives
// about 0.3 (a uniform error over one step).
constexpr double kMinNoiseSteps = 0.3;
// Fewest readings in a window for the test to speak.
constexpr int kMinWindowReadings = 5;
// The window's readings are those of every other pixel of every other row from its corner:
// 16 of a 7 x 7 window, which tell a strip from the plane as the 49 do (on the validation split)
// at a third of the cost.
constexpr int kWindowStride = 2;

// What a region's test needs: its plane and its noise (sigma = noise_k z^2, mm for z in mm);
// usable is false for a region whose moments give no plane.
struct RegionPlane {
  bool usable = false;
  PinholePlane plane;  // in millimetres
  float noise_k = 0.0f;
};

// The test of crease_strips.h, in millimetres (the depth image's unit).
class CreaseTest {
 public:
  CreaseTest(const cv::Mat& depth_mm, const PlaneLabelingParams& params,
             const std::vector<RegionPlane>& planes)
      : depth_(depth_mm),
        planes_(planes),
        // The tolerance max(floor, steps * step(z)), with step(z) = step_k z^2 in mm.
        tolerance_floor_(static_cast<float>(1e3 * params.tolerance.floor_m)),
        tolerance_k_(static_cast<float>(params.tolerance.noise_steps *
                                        params.tolerance.noise.depthStep(1.0) * 1e-3)),
        window_(params.crease_window_px),
        mean_sigmas_(static_cast<float>(params.crease_mean_sigmas)),
        outside_sigmas_(static_cast<float>(params.crease_outside_sigmas)),
        outside_share_(static_cast<float>(params.crease_min_outside_share)) {}

  float reachAt(float z) const {
    return kReachTolerances * std::max(tolerance_floor_, tolerance_k_ * z * z);
  }
  float sigmaAt(int region, float z) const { return planes_[region].noise_k * z * z; }
  float residual(int region, int u, int v, float z) const {
    return planes_[region].plane.residual(u, v, z);
  }
  // The least |residual| of a pixel where a strip's outer edge may lie: the window's mean must
  // pass mean_sigmas of the noise, and along a strip the residuals grow steadily, so the
  // pixel's own lies near its window's mean (half of it leaves room for the noise).
  float leastStripResidual(int region, float z) const {
    return 0.5f * mean_sigmas_ * sigmaAt(region, z);
  }

  // Whether pixel (u, v) of `region` lies on a strip across a crease (see crease_strips.h).
  bool onStrip(int region, int u, int v) const {
    const PinholePlane& plane = planes_[region].plane;
    const float z0 = depth_.at<std::uint16_t>(v, u);
    const float sigma = sigmaAt(region, z0);
    const float reach = reachAt(z0);
    const float outside = outside_sigmas_ * sigma;
    const int u0 = std::max(0, u - window_), u1 = std::min(depth_.cols - 1, u + window_);
    float sum = 0.0f;
    int readings = 0, above = 0, below = 0;
    for (int vv = std::max(0, v - window_); vv <= std::min(depth_.rows - 1, v + window_);
         vv += kWindowStride) {
      const auto* row = depth_.ptr<std::uint16_t>(vv);
      const float row_term = plane.b * static_cast<float>(vv) + plane.c;
      for (int uu = u0; uu <= u1; uu += kWindowStride) {
        if (row[uu] == 0) continue;
        const float z = row[uu];
        const float r = z * (plane.a * static_cast<float>(uu) + row_term) + plane.d;
        if (std::fabs(r) > reach) continue;
        sum += r;
        ++readings;
        above += r > outside;
        below += r < -outside;
      }
    }
    if (readings < kMinWindowReadings) return false;
    const int outside_on_its_side = sum > 0.0f ? above : below;
    return std::fabs(sum) > mean_sigmas_ * sigma * static_cast<float>(readings) &&
           static_cast<float>(outside_on_its_side) >= outside_share_ * static_cast<float>(readings);
  }

 private:
  const cv::Mat& depth_;
  const std::vector<RegionPlane>& planes_;
  float tolerance_floor_, tolerance_k_;
  int window_;
  float mean_sigmas_, outside_sigmas_, outside_share_;
};

// The pixels of a region where a strip's outer edge may lie: off the plane on one side by at
// least leastStripResidual, and beside readings of another label (or none) within reach of
// the plane on that same side, at least kMinOutsideNeighbours of their 8 neighbours. A pixel
// beside a lone reading the labelling left out (noise beyond the tolerance, scattered over
// every plane, on either side) has one such neighbour; one on the edge of a surface running
// on has three.
constexpr int kMinOutsideNeighbours = 2;

// Whether pixel (u, v) of `region` (label region + 1), not on the image's border, is such a
// pixel.
bool onStripEdge(const cv::Mat& depth_mm, const cv::Mat& labels, const CreaseTest& test, int region,
                 int u, int v) {
  const auto l = static_cast<std::uint16_t>(region + 1);
  const float z = depth_mm.at<std::uint16_t>(v, u);
  const float r = test.residual(region, u, v, z);
  if (std::fabs(r) < test.leastStripResidual(region, z)) return false;
  const float reach = test.reachAt(z);
  int outside = 0;
  for (int dv = -1; dv <= 1; ++dv) {
    const auto* labels_row = labels.ptr<std::uint16_t>(v + dv);
    const auto* depth_row = depth_mm.ptr<std::uint16_t>(v + dv);
    for (int du = -1; du <= 1; ++du) {
      if (labels_row[u + du] == l || depth_row[u + du] == 0) continue;
      const float rq = test.residual(region, u + du, v + dv, depth_row[u + du]);
      outside += std::fabs(rq) <= reach && (rq > 0.0f) == (r > 0.0f);
    }
  }
  return outside >= kMinOutsideNeighbours;
}

// The samples near which a strip's outer edge may lie: a sample of a region and the samples
// of its 3 x 3 neighbourhood that belong to another region, or to none, and whose reading lies
// within reach of the region's plane (the strip's edge lies between the two, in either's
// block). Elsewhere a region's pixels end at holes, at lone readings beyond the tolerance, or
// at readings far off its plane (an occluding edge), with nothing to give back.
std::vector<std::uint8_t> borderSamples(const PlaneSampleGrid& grid, const int* region_of,
                                        const CreaseTest& test,
                                        const std::vector<RegionPlane>& planes) {
  const int R = grid.points.rows, C = grid.points.cols;
  std::vector<std::uint8_t> border(static_cast<std::size_t>(R) * C, 0);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < C; ++c) {
      const int own = region_of[r * C + c];
      if (own < 0 || !planes[static_cast<std::size_t>(own)].usable) continue;
      for (int rr = std::max(0, r - 1); rr <= std::min(R - 1, r + 1); ++rr)
        for (int cc = std::max(0, c - 1); cc <= std::min(C - 1, c + 1); ++cc) {
          if (region_of[rr * C + cc] == own) continue;
          const std::uint16_t mm = grid.depth_mm.at<std::uint16_t>(rr, cc);
          if (mm == 0) continue;
          const int u = grid.offset + cc * grid.step, v = grid.offset + rr * grid.step;
          if (std::fabs(test.residual(own, u, v, mm)) > test.reachAt(mm)) continue;
          border[static_cast<std::size_t>(r) * C + c] = 1;
          border[static_cast<std::size_t>(rr) * C + cc] = 1;
        }
    }
  return border;
}

// The pixels nearest sample i of the grid (its step x step block), clipped to the image.
cv::Rect sampleBlock(const PlaneSampleGrid& grid, int r, int c, cv::Size image) {
  const int u0 = grid.offset + c * grid.step - grid.step / 2;
  const int v0 = grid.offset + r * grid.step - grid.step / 2;
  const bool last_col = c + 1 == grid.points.cols, last_row = r + 1 == grid.points.rows;
  const cv::Rect block(u0, v0, last_col ? image.width - u0 : grid.step,
                       last_row ? image.height - v0 : grid.step);
  return block & cv::Rect(0, 0, image.width, image.height);
}

// The strip edge pixels (see above) of the blocks of border samples, in raster order of the
// blocks.
std::vector<cv::Point> stripEdgeCandidates(const cv::Mat& depth_mm, const cv::Mat& labels,
                                           const PlaneSampleGrid& grid, const int* region_of,
                                           const CreaseTest& test,
                                           const std::vector<RegionPlane>& planes) {
  std::vector<cv::Point> out;
  const std::vector<std::uint8_t> border = borderSamples(grid, region_of, test, planes);
  const cv::Rect inner(1, 1, labels.cols - 2, labels.rows - 2);
  for (int r = 0; r < grid.points.rows; ++r)
    for (int c = 0; c < grid.points.cols; ++c) {
      if (!border[static_cast<std::size_t>(r) * grid.points.cols + c]) continue;
      const cv::Rect block = sampleBlock(grid, r, c, labels.size()) & inner;
      for (int v = block.y; v < block.y + block.height; ++v) {
        const auto* up = labels.ptr<std::uint16_t>(v - 1);
        const auto* row = labels.ptr<std::uint16_t>(v);
        const auto* down = labels.ptr<std::uint16_t>(v + 1);
        for (int u = block.x; u < block.x + block.width; ++u) {
          const std::uint16_t l = row[u];
          if (l == 0 || (row[u - 1] == l && row[u + 1] == l && up[u] == l && down[u] == l))
            continue;
          if (planes[l - 1].usable && onStripEdge(depth_mm, labels, test, l - 1, u, v))
            out.emplace_back(u, v);
        }
      }
    }
  return out;
}

// Takes pixel p (about to be unlabelled) out of its region's count, moments and colour (the
// moments and colour hold the pixels of the lattice labelPixels sums them on).
void removeFromRegion(const cv::Mat& depth_mm, const CameraIntrinsics& K, const cv::Mat& bgr,
                      cv::Point p, RegionAccumulator& region) {
  region.count -= 1;
  if (p.x % kMomentStride != 0 || p.y % kMomentStride != 0) return;
  const double z = 1e-3 * depth_mm.at<std::uint16_t>(p);
  region.moments.add((p.x - K.cx) / K.fx * z, (p.y - K.cy) / K.fy * z, z, -1.0);
  if (bgr.empty()) return;
  const cv::Vec3b& c = bgr.at<cv::Vec3b>(p);
  for (int ch = 0; ch < 3; ++ch) region.colour[ch] -= c[ch];
}

// Whether a peeled pixel lay on the bounding box of its region: only then may the box shrink.
bool onBounds(cv::Point p, const RegionAccumulator& region) {
  return p.x == region.u0 || p.x == region.u1 || p.y == region.v0 || p.y == region.v1;
}

// Whether the pixels [u0, u1] x [v0, v1] hold one of region k (a label whose root is k).
bool holdsRegion(const cv::Mat& labels, const std::vector<int>& root, int k, int u0, int u1, int v0,
                 int v1) {
  for (int v = v0; v <= v1; ++v) {
    const auto* row = labels.ptr<std::uint16_t>(v);
    for (int u = u0; u <= u1; ++u)
      if (row[u] != 0 && root[row[u] - 1] == k) return true;
  }
  return false;
}

// Region k's bounds moved in past the rows and columns that no longer hold it (peeling takes
// pixels off its edges, rarely more than a few rows or columns of them).
void shrinkBounds(const cv::Mat& labels, const std::vector<int>& root, int k,
                  RegionAccumulator& region) {
  int &u0 = region.u0, &u1 = region.u1, &v0 = region.v0, &v1 = region.v1;
  while (v0 <= v1 && !holdsRegion(labels, root, k, u0, u1, v0, v0)) ++v0;
  while (v1 >= v0 && !holdsRegion(labels, root, k, u0, u1, v1, v1)) --v1;
  if (v0 > v1) {  // nothing left: the region goes (its count is 0)
    u0 = labels.cols, v0 = labels.rows, u1 = v1 = -1;
    return;
  }
  while (!holdsRegion(labels, root, k, u0, u0, v0, v1)) ++u0;
  while (!holdsRegion(labels, root, k, u1, u1, v0, v1)) --u1;
}

// What both steps change: the regions' sums, the labels, and their record.
struct GiveBack {
  GiveBack(const cv::Mat& depth_mm, const CameraIntrinsics& K, const cv::Mat& bgr,
           const std::vector<int>& root, std::vector<RegionAccumulator>& regions, cv::Mat& labels,
           cv::Mat& peeled_pixels)
      : depth_mm(depth_mm),
        K(K),
        bgr(bgr),
        root(root),
        regions(regions),
        labels(labels),
        peeled_pixels(peeled_pixels),
        peeled_from(regions.size(), 0),
        stale_bounds(regions.size(), 0) {}

  const cv::Mat& depth_mm;
  const CameraIntrinsics& K;
  const cv::Mat& bgr;
  const std::vector<int>& root;
  std::vector<RegionAccumulator>& regions;
  cv::Mat& labels;
  cv::Mat& peeled_pixels;
  std::vector<std::uint8_t> peeled_from;   // per root: whether it lost pixels
  std::vector<std::uint8_t> stale_bounds;  // per root: whether its bounds may shrink

  // Unlabels pixel p of region label - 1.
  void pixel(cv::Point p, std::uint16_t label) {
    const int k = root[label - 1];
    RegionAccumulator& region = regions[k];
    removeFromRegion(depth_mm, K, bgr, p, region);
    peeled_from[k] = 1;
    if (onBounds(p, region)) stale_bounds[k] = 1;
    labels.at<std::uint16_t>(p) = 0;
    if (peeled_pixels.empty()) peeled_pixels = cv::Mat::zeros(labels.size(), CV_8UC1);
    peeled_pixels.at<std::uint8_t>(p) = 1;
  }
};

// peelCreaseStrips: strips peeled pass by pass from the regions' boundaries.
void peelStrips(const PlaneSampleGrid& grid, const int* region_of,
                const PlaneLabelingParams& params, const std::vector<double>& noise_steps,
                GiveBack& give) {
  const std::vector<RegionAccumulator>& regions = give.regions;
  const std::vector<int>& root = give.root;
  const cv::Mat& labels = give.labels;
  // Each root's plane, for the regions merged into it (with their own noise).
  std::vector<RegionPlane> planes(regions.size());
  for (std::size_t k = 0; k < regions.size(); ++k) {
    if (root[k] != static_cast<int>(k)) continue;
    const PlaneFit fit = regions[k].moments.fit();
    if (fit.valid) planes[k] = {true, pinholePlane(fit.normal, 1e3 * fit.d, give.K), 0.0f};
  }
  const PlaneTolerance& tol = params.tolerance;
  for (std::size_t k = 0; k < regions.size(); ++k) {
    if (!planes[root[k]].usable) continue;
    // The region's noise in depth steps: its plane's (a third of the tolerance when too few
    // samples tell it), at least kMinNoiseSteps. sigma(z) = steps x depthStep(z), which grows
    // with z^2; for z and sigma in mm, the coefficient is a thousandth of its value at 1 m.
    const double measured = noise_steps[regions[k].plane];
    const double steps =
        std::max(measured >= 0.0 ? measured : tol.noise_steps / 3.0, kMinNoiseSteps);
    planes[k] = {true, planes[root[k]].plane,
                 static_cast<float>(1e-3 * steps * tol.noise.depthStep(1.0))};
  }
  const CreaseTest test(give.depth_mm, params, planes);
  std::vector<cv::Point> candidates =
      stripEdgeCandidates(give.depth_mm, labels, grid, region_of, test, planes);
  if (candidates.empty()) return;
  // Pixels queued as candidates already (each is tested once).
  cv::Mat queued = cv::Mat::zeros(labels.size(), CV_8UC1);
  for (const cv::Point& p : candidates) queued.at<std::uint8_t>(p) = 1;
  std::vector<cv::Point> peeled;
  for (int pass = 0; pass < params.crease_max_passes && !candidates.empty(); ++pass) {
    peeled.clear();
    for (const cv::Point& p : candidates)
      if (test.onStrip(labels.at<std::uint16_t>(p) - 1, p.x, p.y)) peeled.push_back(p);
    candidates.clear();
    for (const cv::Point& p : peeled) {
      const std::uint16_t label = labels.at<std::uint16_t>(p);
      give.pixel(p, label);
      // The strip goes on inwards: its pixels next to the peeled ones are tested next.
      for (const cv::Point& step :
           {cv::Point(-1, 0), cv::Point(1, 0), cv::Point(0, -1), cv::Point(0, 1)}) {
        const cv::Point q = p + step;
        if (q.x < 0 || q.y < 0 || q.x >= labels.cols || q.y >= labels.rows) continue;
        if (labels.at<std::uint16_t>(q) != label || queued.at<std::uint8_t>(q)) continue;
        queued.at<std::uint8_t>(q) = 1;
        candidates.push_back(q);
      }
    }
  }
}

// Some of region k's points on the lattice its moments are summed on, evenly spread: those of
// a coarser lattice, a multiple of that one, whose cells over the region's bounds number about
// `cells` (reading every pixel of a wall's bounds cost more than the fits).
void latticePoints(const GiveBack& give, int k, double cells,
                   std::vector<Eigen::Vector3d>& points) {
  const RegionAccumulator& region = give.regions[k];
  const double area = static_cast<double>(region.u1 - region.u0 + 1) * (region.v1 - region.v0 + 1);
  const int stride =
      kMomentStride * std::max(1, static_cast<int>(std::sqrt(area / cells) / kMomentStride));
  const auto first = [stride](int i) { return (i + stride - 1) / stride * stride; };
  points.clear();
  for (int v = first(region.v0); v <= region.v1; v += stride) {
    const auto* row = give.labels.ptr<std::uint16_t>(v);
    const auto* z = give.depth_mm.ptr<std::uint16_t>(v);
    for (int u = first(region.u0); u <= region.u1; u += stride)
      if (row[u] && z[u] && give.root[row[u] - 1] == k)
        points.push_back(give.K.backproject(u, v, 1e-3 * z[u]));
  }
}

// giveBackSmallerFaces: a region whose pixels two planes fit much better than its own plane,
// planes that meet at a crease or lie apart by more than the sensor resolves, gives back the
// pixels of the smaller face. The one plane and the two are fitted to the same few hundred of
// its pixels (a two-plane fit takes at most TwoPlaneFit::kMaxFitPoints anyway); the region's own
// fit, on all its pixels, only tells which regions to try.
void giveBackSmaller(const PlaneLabelingParams& params, GiveBack& give) {
  // A face of fewer than this share of the fitted points is a strip the peeling is for, or a
  // few outliers; either way no second face to fit.
  constexpr double kMinFaceShare = 0.15;
  // Two planes cannot fit much better than the sensor's quantisation (a third of a depth step
  // from the rounding alone), so a region whose plane fits within half a step holds no second
  // face the test could find, and most regions do: the fits are spared for them.
  constexpr double kMinRmsSteps = 0.5;
  const double min_cos = std::cos(degToRad(params.minor_face_min_angle_deg));
  std::vector<Eigen::Vector3d> x;
  for (std::size_t k = 0; k < give.regions.size(); ++k) {
    const RegionAccumulator& region = give.regions[k];
    if (give.root[k] != static_cast<int>(k) || region.count == 0 || region.curved) continue;
    const PlaneFit own = region.moments.fit();
    if (!own.valid || own.rms_m < kMinRmsSteps * params.tolerance.noise.depthStep(own.centroid.z()))
      continue;
    latticePoints(give, static_cast<int>(k), 4.0 * TwoPlaneFit::kMaxFitPoints, x);
    PlaneMoments moments;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : x) {
      moments.add(p);
      sum += p;
    }
    const PlaneFit one = moments.fit();
    if (!one.valid) continue;
    const std::optional<TwoPlaneFit> two = bestTwoPlanes(x, sum / static_cast<double>(x.size()));
    if (!two || one.rms_m < params.minor_face_gain * two->rms() ||
        !two->facesHoldAtLeast(kMinFaceShare * static_cast<double>(x.size())))
      continue;
    const bool minor_is_b = two->planes.b.count < two->planes.a.count;
    const PlaneFit& larger = minor_is_b ? two->planes.a : two->planes.b;
    const PlaneFit& smaller = minor_is_b ? two->planes.b : two->planes.a;
    const bool at_a_crease = std::fabs(larger.normal.dot(smaller.normal)) <= min_cos;
    const bool apart =
        larger.distance(smaller.centroid) >=
        params.minor_face_min_gap_steps * params.tolerance.noise.depthStep(smaller.centroid.z());
    if (!at_a_crease && !apart) continue;
    for (int v = region.v0; v <= region.v1; ++v)
      for (int u = region.u0; u <= region.u1; ++u) {
        const std::uint16_t label = give.labels.at<std::uint16_t>(v, u);
        const std::uint16_t z = give.depth_mm.at<std::uint16_t>(v, u);
        if (!label || !z || give.root[label - 1] != static_cast<int>(k)) continue;
        if (two->planes.nearerB(give.K.backproject(u, v, 1e-3 * z)) == minor_is_b)
          give.pixel({u, v}, label);
      }
  }
}

// Both steps' end: the bounds that may have shrunk are taken again.
std::vector<std::uint8_t> finish(GiveBack& give) {
  for (std::size_t k = 0; k < give.regions.size(); ++k)
    if (give.stale_bounds[k])
      shrinkBounds(give.labels, give.root, static_cast<int>(k), give.regions[k]);
  return std::move(give.peeled_from);
}

}  // namespace

std::vector<std::uint8_t> peelCreaseStrips(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                           const cv::Mat& bgr, const PlaneSampleGrid& grid,
                                           const int* region_of, const PlaneLabelingParams& params,
                                           const std::vector<double>& noise_steps,
                                           const std::vector<int>& root,
                                           std::vector<RegionAccumulator>& regions, cv::Mat& labels,
                                           cv::Mat& peeled_pixels) {
  CV_Assert(root.size() == regions.size());
  peeled_pixels.release();
  GiveBack give(depth_mm, K, bgr, root, regions, labels, peeled_pixels);
  if (params.crease_max_passes > 0) peelStrips(grid, region_of, params, noise_steps, give);
  return finish(give);
}

std::vector<std::uint8_t> giveBackSmallerFaces(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                               const cv::Mat& bgr,
                                               const PlaneLabelingParams& params,
                                               const std::vector<int>& root,
                                               std::vector<RegionAccumulator>& regions,
                                               cv::Mat& labels, cv::Mat& peeled_pixels) {
  CV_Assert(root.size() == regions.size());
  GiveBack give(depth_mm, K, bgr, root, regions, labels, peeled_pixels);
  if (params.minor_face_gain > 0.0) giveBackSmaller(params, give);
  return finish(give);
}

}  // namespace shapesense::labeling
