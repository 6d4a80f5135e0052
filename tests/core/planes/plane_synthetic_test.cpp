// Plane detectors against the synthetic scene's exact ground truth (issue 4 targets).
//
// Truth regions: truth.surface_labels restricted to planar surfaces; a truth plane is counted
// when it covers >= 0.5% of the image; correct detection is SegComp's at T = 0.8. Plane errors
// (angle between normals, |d - d_truth|) are taken over correctly detected truth planes.
#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "shapesense/core/planes/plane_accumulator.h"
#include "shapesense/core/planes/plane_ransac.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/plane_eval.h"
#include "shapesense/eval/scene_splits.h"

namespace shapesense {
namespace {

using eval::median;

// 10 frames: seeds 1-5 (five different table-top layouts), frames 0 and 15 of each (the camera
// sways between them).
template <typename Detect>
eval::PlaneScore scoreTenFrames(const char* tag, Detect&& detect) {
  eval::PlaneScore total;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    const synthetic::SyntheticScene scene(sp);
    for (std::uint64_t frame : {0, 15}) {
      const auto f = scene.render(frame, 0);
      const PlaneDetection out = detect(f);
      const auto s = eval::scorePlanes(out.labels, out.planes, f.truth);
      std::printf("[%s] seed %llu frame %llu: %d/%d correct, %zu regions\n", tag,
                  static_cast<unsigned long long>(seed), static_cast<unsigned long long>(frame),
                  s.correct, s.truth_regions, out.planes.size());
      total.add(s);
    }
  }
  std::printf("[%s] correct %.3f (%d/%d), median angle %.3f deg, median distance %.2f mm\n", tag,
              total.correctFraction(), total.correct, total.truth_regions, median(total.angle_deg),
              1e3 * median(total.dist_m));
  return total;
}

eval::PlaneScore houghTenFrames() {
  HoughPlaneDetector det;
  return scoreTenFrames("hough", [&](const synthetic::RenderedFrame& f) {
    return det.detect(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
  });
}

TEST(PlaneSynthetic, HoughMeetsIssueErrorTargets) {
  const auto total = houghTenFrames();
  ASSERT_GT(total.truth_regions, 50);
  EXPECT_LE(median(total.angle_deg), 1.0);  // degrees, issue target (reached: 0.09)
  EXPECT_LE(median(total.dist_m), 0.01);    // metres, issue target (reached: 0.0008)
}

// Issue target: correct detection >= 0.9. Reached 0.947 (126/133) on these 10 frames and 0.902
// (340/377) on the 30 frames of planes_bench. Remaining misses: leg faces merged with the
// neighbouring face at range, small box faces without reliable normals.
TEST(PlaneSynthetic, HoughMeetsIssueCorrectDetectionTarget) {
  EXPECT_GE(houghTenFrames().correctFraction(), 0.9);
}

using TrainCases = std::vector<std::pair<int, std::vector<std::string>>>;

// The named truth planes of the train split's frames that `det` finds (SegComp correct), as
// "frame: name". Train frames: no parameter was chosen on them.
std::vector<std::string> foundOnTrainFrames(const TrainCases& cases, HoughPlaneDetector& det) {
  std::vector<std::string> found;
  for (const auto& [index, names] : cases) {
    const eval::EvalScene scene = eval::evalScene(eval::Split::kTrain, index);
    const auto f = synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
    const PlaneDetection out = det.detect(f.frame.depth, f.frame.intrinsics);
    const eval::PlaneScore score = eval::scorePlanes(out.labels, out.planes, f.truth);
    for (const std::string& name : names) {
      const auto surface =
          std::find_if(f.truth.surfaces.begin(), f.truth.surfaces.end(),
                       [&](const synthetic::TruthSurface& s) { return s.name == name; });
      EXPECT_NE(surface, f.truth.surfaces.end()) << name;
      if (surface == f.truth.surfaces.end()) continue;
      if (std::any_of(score.matches.begin(), score.matches.end(),
                      [&](const auto& m) { return m.first == surface->id; }))
        found.push_back(std::to_string(index) + ": " + name);
    }
  }
  return found;
}

std::size_t planeCount(const TrainCases& cases) {
  std::size_t count = 0;
  for (const auto& [index, names] : cases) count += names.size();
  return count;
}

// A face only a few samples wide between two creases (a table leg's sides, the side of a box
// seen obliquely) has no sample normal that is not blurred across the creases. Each is still
// found as a plane of its own: frame 28 shows a leg's left and back faces (0.8% and 1.1% of the
// image at 1.25 m), frame 1 a leg's right and front faces (1.0% and 0.8% at 1.3 m) and a box side
// (1.1% at 0.85 m).
TEST(PlaneSynthetic, NarrowFacesBetweenCreasesAreFound) {
  const TrainCases cases = {
      {28, {"table_leg4_face_left", "table_leg4_face_back"}},
      {1, {"table_leg1_face_right", "table_leg1_face_front", "box3_face_left"}}};
  HoughPlaneDetector det;
  EXPECT_EQ(foundOnTrainFrames(cases, det).size(), planeCount(cases));
}

// Farther away, both faces of a leg lie within the tolerance of one plane through their crease
// (the tolerance grows with the square of the range, the leg's width only linearly); two planes
// fit their samples far better, and they are two planes (HoughPlaneParams::two_face_gain). Legs
// at 1.6 m (frames 6 and 46, 0.6-1.0% of the image each) and 2.15 m (frame 44, 0.5-0.6%):
// without that test none of these six faces is found.
TEST(PlaneSynthetic, BothFacesOfALegAtRangeAreFound) {
  const TrainCases cases = {{6, {"table_leg2_face_left", "table_leg2_face_front"}},
                            {44, {"table_leg3_face_left", "table_leg3_face_back"}},
                            {46, {"table_leg2_face_left", "table_leg2_face_front"}}};
  HoughPlaneDetector det;
  EXPECT_EQ(foundOnTrainFrames(cases, det).size(), planeCount(cases));
  HoughPlaneParams one_face;
  one_face.two_face_gain = 0.0;
  HoughPlaneDetector without(one_face);
  EXPECT_TRUE(foundOnTrainFrames(cases, without).empty());
}

TEST(PlaneSynthetic, HoughOutputIsConsistent) {
  synthetic::SceneParams sp;
  sp.seed = 2;
  const auto f = synthetic::SyntheticScene(sp).render(0, 0);
  HoughPlaneDetector det;
  const auto out = det.detect(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
  ASSERT_FALSE(out.planes.empty());
  ASSERT_EQ(out.labels.type(), CV_16UC1);
  ASSERT_EQ(out.labels.size(), f.frame.depth.size());
  std::vector<std::size_t> count(out.planes.size() + 1, 0);
  for (int v = 0; v < out.labels.rows; ++v)
    for (int u = 0; u < out.labels.cols; ++u) {
      const auto l = out.labels.at<std::uint16_t>(v, u);
      ASSERT_LE(l, out.planes.size());
      if (l) {
        ASSERT_NE(f.frame.depth.at<std::uint16_t>(v, u), 0);  // labels only where there is depth
      }
      ++count[l];
    }
  for (std::size_t k = 0; k < out.planes.size(); ++k) {
    const auto& p = out.planes[k];
    EXPECT_EQ(p.id, k + 1);
    EXPECT_EQ(p.inliers, count[p.id]);
    EXPECT_NEAR(p.normal.norm(), 1.0, 1e-9);
    EXPECT_GT(p.d, 0.0);
    EXPECT_LT(p.rms_m, 0.05);
    EXPECT_TRUE(p.mean_bgr.has_value());
    EXPECT_GE(p.polygon.size(), 3u) << "plane " << p.id;
    EXPECT_EQ(p.triangles.size() + 2, p.polygon.size()) << "plane " << p.id;
    for (const auto& v : p.polygon) EXPECT_NEAR(p.normal.dot(v) + p.d, 0.0, 1e-6);  // on the plane
    // Bounding box holds the inliers.
    const cv::Mat roi = out.labels(p.box);
    EXPECT_EQ(static_cast<std::size_t>(cv::countNonZero(roi == p.id)), p.inliers);
  }
}

TEST(PlaneSynthetic, RansacBaselineSanity) {
  // The baseline finds the big planes correctly, but without normals it misses small faces and
  // lets planes claim bands of crossing surfaces, so it is well below the Hough detector.
  const auto total = scoreTenFrames("ransac", [&](const synthetic::RenderedFrame& f) {
    return detectPlanesRansac(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
  });
  EXPECT_GE(total.correctFraction(), 0.3);
  EXPECT_LE(median(total.angle_deg), 2.0);
  EXPECT_LE(median(total.dist_m), 0.02);
}

TEST(PlaneSynthetic, AccumulationOverStaticFramesBeatsSingleFrames) {
  // 30 frames of a static scene (camera_motion = 0): the noise is drawn anew per frame, so the
  // accumulated planes average it out. Compared on the truth planes that the last frame detects
  // correctly; the accumulated plane is the track nearest to that frame's plane. Paired: each
  // such truth plane contributes its accumulated error and the median of its single-frame
  // errors (small planes have larger errors; an unpaired median would compare different mixes).
  std::vector<double> single_angle, single_dist, acc_angle, acc_dist;
  std::size_t single_count = 0;
  for (std::uint64_t seed : {1, 4}) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    sp.camera_motion = 0.0;
    sp.render_colour = false;
    const synthetic::SyntheticScene scene(sp);
    HoughPlaneDetector det;
    PlaneAccumulator acc;
    eval::PlaneScore last;
    PlaneDetection last_out;
    synthetic::TruthFrame last_truth;
    std::map<int, std::vector<double>> per_truth_angle, per_truth_dist;  // single-frame errors
    for (std::uint64_t i = 0; i < 30; ++i) {
      auto f = scene.render(i, 0);
      auto out = det.detect(f.frame.depth, f.frame.intrinsics);
      acc.update(out);
      last = eval::scorePlanes(out.labels, out.planes, f.truth);
      for (std::size_t k = 0; k < last.matches.size(); ++k) {
        per_truth_angle[last.matches[k].first].push_back(last.angle_deg[k]);
        per_truth_dist[last.matches[k].first].push_back(last.dist_m[k]);
        ++single_count;
      }
      last_out = std::move(out);
      last_truth = std::move(f.truth);
    }
    EXPECT_EQ(acc.resets(), 0u);
    const auto planes = acc.planes();
    ASSERT_FALSE(planes.empty());
    for (const auto& [tid, fid] : last.matches) {
      const auto& fp = last_out.planes[fid - 1];
      const auto& ts = last_truth.surfaces[tid - 1];
      ASSERT_EQ(ts.id, tid);
      const DetectedPlane* best = nullptr;
      double best_cost = 1e9;
      for (const auto& p : planes) {
        const double cost = std::acos(std::clamp(p.normal.dot(fp.normal), -1.0, 1.0)) * 57.3 +
                            100 * std::fabs(p.d - fp.d);
        if (cost < best_cost) {
          best_cost = cost;
          best = &p;
        }
      }
      ASSERT_NE(best, nullptr);
      if (best_cost > 3.0) continue;  // not a stable plane of the accumulator
      const Eigen::Vector3d tn = ts.plane.head<3>();
      acc_angle.push_back(std::acos(std::clamp(std::fabs(best->normal.dot(tn)), 0.0, 1.0)) * 180.0 /
                          M_PI);
      acc_dist.push_back(std::fabs(best->d - ts.plane[3]));
      single_angle.push_back(median(per_truth_angle[tid]));
      single_dist.push_back(median(per_truth_dist[tid]));
    }
  }
  const double sa = median(single_angle), sd = median(single_dist);
  const double aa = median(acc_angle), ad = median(acc_dist);
  std::printf(
      "[accumulate] %zu truth planes (%zu single-frame detections): median over planes of the "
      "single-frame "
      "median %.4f deg %.3f mm; accumulated 30 frames: %.4f deg %.3f mm\n",
      acc_angle.size(), single_count, sa, 1e3 * sd, aa, 1e3 * ad);
  ASSERT_GE(acc_angle.size(), 10u);
  EXPECT_LT(aa, sa);
  EXPECT_LT(ad, sd);
}

}  // namespace
}  // namespace shapesense
