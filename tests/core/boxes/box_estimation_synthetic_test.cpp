// estimateBox against ground truth: synthetic table-top scenes (driver's SyntheticScene), every
// visible non-table object with one of its true 2D boxes as ROI. Measures, per mode, the
// fraction of the object's measured 3D points inside the estimated box and the estimated / true
// volume ratio. The target for mode 2: containment >= 0.95 with volume <= 2.5x the true
// box's (asserted on the medians over all objects).
// Two ROIs, because "the object's true 2D box" has two readings (see RoiKind):
//  - the projection of the object's true box (mode 2's premise: the ROI contains the whole
//    projection of the box). Here the target is asserted.
//  - the bounds of its visible pixels (a silhouette). Mode 2's geometry (the box's projection
//    must stay inside the ROI) cannot reach 0.95 with it: points that project near the ROI's
//    edge at a depth other than the bounding face's are outside whatever the face depths are.
//    mode2Oracle measures the best containment any face depths could give (median ~0.88), and
//    the test asserts that mode 2 reaches at least 90% of that ceiling.
// Modes 1 and 3 are reported (their ROI is a front face, which neither ROI is), with sanity
// bounds only.

#include <algorithm>
#include <cstdint>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

struct Sample {
  std::string kind;
  double containment = 0.0;
  double volume_ratio = 0.0;
};

// Mode 2 with hindsight: the best containment any pair of face depths (z1, z2) could give with
// mode 2's geometry (2 % quantile grid over the object's own visible depths; faces outside
// that range only shrink the box's x/y or add nothing). Bounds what statistics can reach: the
// box's projection must stay inside the ROI, so object points that project near the ROI edge
// at a depth other than the bounding face's are outside whatever the depths are.
double mode2Oracle(const std::vector<Eigen::Vector3d>& points, const CameraIntrinsics& k,
                   const cv::Rect& r) {
  std::vector<double> zs;
  for (const auto& p : points) zs.push_back(p.z());
  std::sort(zs.begin(), zs.end());
  const double xl = (r.x - 0.5 - k.cx) / k.fx, xr = (r.x + r.width - 0.5 - k.cx) / k.fx;
  const double yt = (r.y - 0.5 - k.cy) / k.fy, yb = (r.y + r.height - 0.5 - k.cy) / k.fy;
  const auto extent = [](double a, double b, double z1, double z2, double& lo, double& hi) {
    lo = a * (a > 0 ? z2 : z1);
    hi = b * (b < 0 ? z2 : z1);
    if (lo > hi) lo = hi = 0.5 * (lo + hi);
  };
  double best = 0.0;
  for (int i = 0; i <= 50; i += 2) {
    for (int j = 50; j <= 100; j += 2) {
      const double z1 = zs[std::min(zs.size() - 1, zs.size() * i / 100)];
      const double z2 = zs[std::min(zs.size() - 1, zs.size() * j / 100)];
      double x0, x1, y0, y1;
      extent(xl, xr, z1, z2, x0, x1);
      extent(yt, yb, z1, z2, y0, y1);
      std::size_t inside = 0;
      for (const auto& p : points) {
        inside +=
            p.z() >= z1 && p.z() <= z2 && p.x() >= x0 && p.x() <= x1 && p.y() >= y0 && p.y() <= y1;
      }
      best = std::max(best, static_cast<double>(inside) / points.size());
    }
  }
  return best;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

// Objects with fewer visible pixels are mostly hidden or cut off: their 2D box says little.
constexpr std::size_t kMinObjectPixels = 200;
constexpr int kScenes = 10;  // one frame from each of 10 scenes (seeds 1..10): varied layouts

// Which 2D box of the object is the ROI.
enum class RoiKind {
  /// Bounds of the object's labelled pixels: what a detector or an operator outlining the
  /// visible object draws.
  kSilhouette,
  /// Bounds of the projection of the object's true box made axis-aligned in the camera frame
  /// (the box of its 8 true corners): exactly mode 2's premise, "the ROI contains the whole
  /// projection of an axis-aligned box".
  kProjectedBox,
};

// The projected true box; empty when any of it falls outside the image (then the ROI would be
// clipped and no longer contain the projection).
cv::Rect projectedAxisAlignedBox(const synthetic::TruthObject& object, const CameraIntrinsics& k,
                                 cv::Size image) {
  Eigen::Vector3d lo = object.corners[0], hi = object.corners[0];
  for (const auto& c : object.corners) {
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  }
  if (lo.z() <= 0.0) return {};
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d c((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                            (i & 4) ? hi.z() : lo.z());
    const Eigen::Vector2d p = k.project(c);
    u0 = std::min(u0, p.x());
    v0 = std::min(v0, p.y());
    u1 = std::max(u1, p.x());
    v1 = std::max(v1, p.y());
  }
  // Inclusive pixels whose footprint [u - 0.5, u + 0.5] covers the projection.
  const cv::Point tl(static_cast<int>(std::floor(u0 + 0.5)),
                     static_cast<int>(std::floor(v0 + 0.5)));
  const cv::Point br(static_cast<int>(std::ceil(u1 - 0.5)), static_cast<int>(std::ceil(v1 - 0.5)));
  const cv::Rect r(tl, br + cv::Point(1, 1));
  return (r & cv::Rect({0, 0}, image)) == r ? r : cv::Rect{};
}

std::map<BoxMode, std::vector<Sample>> measure(RoiKind roi, std::vector<double>* oracle) {
  std::map<BoxMode, std::vector<Sample>> out;
  const std::array<BoxMode, 3> modes{BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained,
                                     BoxMode::kAxisAlignedFrontFace};
  for (int s = 1; s <= kScenes; ++s) {
    synthetic::SceneParams params;
    params.seed = static_cast<std::uint64_t>(s);
    params.render_colour = false;
    const synthetic::SyntheticScene scene(params);
    const synthetic::RenderedFrame rendered = scene.render(0, 0);
    const cv::Mat& depth = rendered.frame.depth;
    const CameraIntrinsics& k = rendered.frame.intrinsics;
    const cv::Mat& labels = rendered.truth.object_labels;
    for (const auto& object : rendered.truth.objects) {
      if (object.kind == "table" || object.image_box.empty() ||
          object.pixel_count < kMinObjectPixels) {
        continue;
      }
      const cv::Rect r = roi == RoiKind::kSilhouette
                             ? object.image_box
                             : projectedAxisAlignedBox(object, k, depth.size());
      if (r.empty()) continue;
      // The object's visible points, from the measured depth.
      std::vector<Eigen::Vector3d> points;
      for (int v = r.y; v < r.y + r.height; ++v) {
        for (int u = r.x; u < r.x + r.width; ++u) {
          const auto d = depth.at<std::uint16_t>(v, u);
          if (d == 0 || labels.at<std::uint16_t>(v, u) != object.id) continue;
          points.push_back(k.backproject(u, v, d * 0.001));
        }
      }
      if (points.empty()) continue;
      const double true_volume = object.size.prod();
      oracle->push_back(mode2Oracle(points, k, r));
      for (BoxMode mode : modes) {
        const auto result =
            estimateBox(depth, k, r.tl(), {r.x + r.width - 1, r.y + r.height - 1}, mode);
        const auto* box = std::get_if<BoxEstimate>(&result);
        if (box == nullptr) {
          ADD_FAILURE() << "no box for " << object.name << " in scene " << s << ": "
                        << std::get<BoxEstimationFailure>(result).message;
          continue;
        }
        std::size_t inside = 0;
        for (const auto& p : points) inside += boxContains(box->corners, p) ? 1 : 0;
        out[mode].push_back({object.kind, static_cast<double>(inside) / points.size(),
                             boxVolume(box->corners) / true_volume});
      }
    }
  }
  return out;
}

std::string summary(const std::vector<Sample>& samples, double* median_containment,
                    double* median_volume) {
  std::vector<double> c, v;
  for (const auto& s : samples) {
    c.push_back(s.containment);
    v.push_back(s.volume_ratio);
  }
  *median_containment = quantile(c, 0.5);
  *median_volume = quantile(v, 0.5);
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << "n=" << samples.size() << " containment median "
     << *median_containment << " (p10 " << quantile(c, 0.1) << ", min " << quantile(c, 0.0)
     << ") volume ratio median " << *median_volume << " (p90 " << quantile(v, 0.9) << ", max "
     << quantile(v, 1.0) << ")";
  // Per kind, to see where a mode struggles.
  std::map<std::string, std::vector<const Sample*>> by_kind;
  for (const auto& s : samples) by_kind[s.kind].push_back(&s);
  for (const auto& [kind, list] : by_kind) {
    std::vector<double> kc, kv;
    for (const auto* s : list) {
      kc.push_back(s->containment);
      kv.push_back(s->volume_ratio);
    }
    os << "\n    " << kind << " n=" << list.size() << " containment median " << quantile(kc, 0.5)
       << " volume median " << quantile(kv, 0.5);
  }
  return os.str();
}

struct Medians {
  double containment = 0.0;
  double volume_ratio = 0.0;
};

// Prints one mode's figures under `label`, records them as test properties named after
// `key_prefix` and the mode, and returns the medians.
Medians report(const std::string& label, const std::string& key_prefix, BoxMode mode,
               const std::vector<Sample>& samples) {
  Medians m;
  const std::string text = summary(samples, &m.containment, &m.volume_ratio);
  std::cout << "[ " << label << " ] mode " << static_cast<int>(mode) << " (" << toString(mode)
            << "): " << text << "\n";
  const std::string key = key_prefix + std::to_string(static_cast<int>(mode));
  ::testing::Test::RecordProperty(key + "_median_containment", std::to_string(m.containment));
  ::testing::Test::RecordProperty(key + "_median_volume_ratio", std::to_string(m.volume_ratio));
  return m;
}

TEST(BoxEstimationSynthetic, ContainmentAndVolumeAgainstGroundTruth) {
  std::vector<double> oracle;
  const auto results = measure(RoiKind::kSilhouette, &oracle);
  const double oracle_median = quantile(oracle, 0.5);
  std::cout << "[ box vs truth ] mode 2 best possible (any face depths, hindsight): containment "
            << "median " << oracle_median << "\n";
  RecordProperty("mode2_oracle_median_containment", std::to_string(oracle_median));
  for (BoxMode mode :
       {BoxMode::kFrustumAligned, BoxMode::kAxisAlignedContained, BoxMode::kAxisAlignedFrontFace}) {
    const auto it = results.find(mode);
    ASSERT_NE(it, results.end()) << toString(mode);
    ASSERT_GE(it->second.size(), 20u) << "too few objects measured";
    const auto [containment, volume] = report("box vs truth", "mode", mode, it->second);
    if (mode == BoxMode::kAxisAlignedContained) {
      // The ceiling itself is below the 0.95: keep checking that, so that a change of
      // the scenes that lifts it shows up here and the target can be asserted again.
      EXPECT_LT(oracle_median, 0.95) << "mode 2 could now reach the issue's 0.95: assert it";
      EXPECT_GE(containment, 0.9 * oracle_median)
          << "mode 2's geometry caps the median at " << oracle_median << " (see mode2Oracle)";
      EXPECT_GE(containment, 0.8);
      EXPECT_LE(volume, 2.5);
    } else {
      // Reported figures; sanity only (a box of the right place and size).
      EXPECT_GE(containment, 0.5) << toString(mode);
      EXPECT_LE(volume, 10.0) << toString(mode);
      EXPECT_GE(volume, 0.1) << toString(mode);
    }
  }
}

// Mode 2 on its own premise: the ROI is the projection of the object's true box (made
// axis-aligned in the camera frame), so a box that holds every visible point exists (the
// hindsight ceiling is 1) and the targets apply to what the statistics choose.
// Failures left in the low tail are occlusions: an object hidden behind another covers a
// minority of its ROI and the robust centre lands on the occluder.
TEST(BoxEstimationSynthetic, Mode2MeetsTargetsWithProjectedTrueBoxAsRoi) {
  std::vector<double> oracle;
  const auto results = measure(RoiKind::kProjectedBox, &oracle);
  const double oracle_median = quantile(oracle, 0.5);
  std::cout << "[ box vs truth, projected-box ROI ] mode 2 best possible (hindsight): "
            << "containment median " << oracle_median << "\n";
  for (const auto& [mode, samples] : results) {
    ASSERT_GE(samples.size(), 20u) << "too few objects wholly in view";
    const auto [containment, volume] =
        report("box vs truth, projected-box ROI", "projected_roi_mode", mode, samples);
    if (mode == BoxMode::kAxisAlignedContained) {
      EXPECT_GE(oracle_median, 0.99) << "the ROI no longer contains the box's projection";
      EXPECT_GE(containment, 0.95);
      EXPECT_LE(volume, 2.5);
    }
  }
}

}  // namespace
}  // namespace shapesense
