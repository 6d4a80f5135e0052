// Plane quality on the evaluation's test split (tools/eval: scenes of a wide distribution
// whose seeds no parameter was chosen on) and on the labelled real OSD frames, against the
// targets of the detection-quality issue (#18). Where the detector does not reach a target
// yet, the test is a regression record: its bound sits under what the code reaches today, and
// the target stays written beside it.

#include <gtest/gtest.h>

#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/eval/plane_eval.h"
#include "shapesense/eval/scene_splits.h"
#include "shapesense/eval/segment_eval.h"
#include "test_paths.h"

namespace shapesense {
namespace {

constexpr int kTestFrames = 60;

struct SplitScores {
  eval::PlaneScore plain, clutter;
};

const SplitScores& testSplitScores() {
  static const SplitScores scores = [] {
    SplitScores s;
    HoughPlaneDetector hough(DetectorConfig{}.hough_params);
    for (int i = 0; i < kTestFrames; ++i) {
      const eval::EvalScene scene = eval::evalScene(eval::Split::kTest, i);
      const auto f = synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
      const PlaneDetection out = hough.detect(f.frame.depth, f.frame.intrinsics);
      (scene.curved_clutter ? s.clutter : s.plain)
          .add(eval::scorePlanes(out.labels, out.planes, f.truth));
    }
    return s;
  }();
  return scores;
}

eval::PlaneScore allScenes() {
  eval::PlaneScore all = testSplitScores().plain;
  all.add(testSplitScores().clutter);
  return all;
}

// Target: median angle error <= 0.5 deg and distance <= 5 mm (reached 0.10 deg, 1.2 mm).
TEST(PlaneQuality, CorrectPlanesMeetTheErrorTargets) {
  const eval::PlaneScore all = allScenes();
  ASSERT_GT(all.correct, 300);
  EXPECT_LE(eval::median(all.angle_deg), 0.5);
  EXPECT_LE(eval::median(all.dist_m), 0.005);
}

// Target: correct >= 0.90 of the truth planes of >= 0.5% of the image.
// Regression record: 0.845 (reached 0.849; 0.856 before regions on two faces gave back the
// smaller, which trades 5 of these 709 planes for 0.16 fewer spurious planes a plain frame).
// The misses are mostly small faces, 0.5-2% of the image: box sides, thin objects, shelf
// boards, table legs.
TEST(PlaneQuality, CorrectDetectionRegressionRecord) {
  EXPECT_GE(allScenes().correctFraction(), 0.845);
}

// Target: <= 0.3 spurious planes per frame on plain scenes and <= 1 with curved clutter.
// Plain scenes, a regression record: 1.0 (reached 0.67). Most that remain hold one face and a
// strip of its neighbour the sensor does not resolve at their range (a shelf board's front and
// top, a table's edge and top) or two coplanar faces with no gap the sensor resolves (the
// fronts of two touching boxes).
// Cluttered scenes: the target itself (reached 0.77 on these 60 frames; 1.12 on the 100 test
// frames of shapesense-eval, docs/benchmarks.md).
TEST(PlaneQuality, SpuriousPlanes) {
  EXPECT_LE(testSplitScores().plain.spuriousPerFrame(), 1.0);
  EXPECT_LE(testSplitScores().clutter.spuriousPerFrame(), 1.0);
}

// Target: the sides of tins, balls and bowls are not planes. Regression record: <= 0.1 plane
// a cluttered frame lying mostly on a curved surface (reached 0.07 with bins, columns, tori and
// mounds in the scenes; what remains are single facets of tins and bowls too narrow at their
// range for a quadric to tell).
TEST(PlaneQuality, CurvedSurfacesRegressionRecord) {
  const eval::PlaneScore& clutter = testSplitScores().clutter;
  ASSERT_GT(clutter.frames, 20);
  EXPECT_LE(clutter.spurious_on_curved, 0.1 * clutter.frames);
}

// The table of every labelled real OSD test frame is found as one plane (>= 80% of its pixels
// with depth in one plane).
TEST(PlaneQuality, RealTableIsOnePlane) {
  const auto dir = testing::realRecording("mosd_test");
  if (!std::filesystem::exists(dir / "depth.txt")) GTEST_SKIP() << "no " << dir;
  HoughPlaneDetector hough(DetectorConfig{}.hough_params);
  int frames = 0, whole = 0;
  for (const auto& f : eval::loadLabelledRecording(dir)) {
    const PlaneDetection out = hough.detect(f.frame.depth, f.frame.intrinsics);
    ++frames;
    whole += eval::tableCoverage(out.labels, f.labels, f.frame.depth) >= 0.8;
  }
  EXPECT_EQ(whole, frames);
}

}  // namespace
}  // namespace shapesense
