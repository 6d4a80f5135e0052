// Segmentation accuracy against the synthetic renderer's ground truth (one label per planar face
// or curved object). Figures are printed; thresholds sit slightly below what each method reaches
// (see the printed table). Depth-step's 0.9 from the issue is unreachable (see below).
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

TEST(SegmentationSynthetic, SegCompAgainstSurfaceLabels) {
  const SegmentationMethod methods[] = {
      SegmentationMethod::kDepthStep, SegmentationMethod::kNormalEdges, SegmentationMethod::kFused,
      SegmentationMethod::kPlanePrediction, SegmentationMethod::kTiledRansac};
  std::map<SegmentationMethod, double> correct, accuracy;
  int frames = 0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    synthetic::SceneParams p;
    p.seed = seed;
    p.render_colour = false;
    const synthetic::SyntheticScene scene(p);
    const synthetic::RenderedFrame f = scene.render(0, 0);
    ++frames;
    for (auto m : methods) {
      const cv::Mat r = segmentDepth(f.frame.depth, f.frame.intrinsics, m);
      const SegCompScore s = scoreSegmentation(r, f.truth.surface_labels, 0.8, 0.005);
      std::printf(
          "[seg synthetic] seed %llu %-16s correct %2d/%2d (%.2f) over %d under %d missed %d  "
          "pixel acc %.3f\n",
          static_cast<unsigned long long>(seed), std::string(formatSegmentationMethod(m)).c_str(),
          s.correct, s.truth_regions, s.correct_fraction, s.over_segmented, s.under_segmented,
          s.missed, s.pixel_accuracy);
      correct[m] += s.correct_fraction;
      accuracy[m] += s.pixel_accuracy;
    }
  }
  for (auto m : methods) {
    correct[m] /= frames;
    accuracy[m] /= frames;
    std::printf("[seg synthetic] mean %-16s correct fraction %.3f  pixel accuracy %.3f\n",
                std::string(formatSegmentationMethod(m)).c_str(), correct[m], accuracy[m]);
  }
  // ISSUE 3 TARGET, KNOWN UNMET (depth_step reaches 0.67): depth-step edges only see depth
  // discontinuities, and many truth surfaces here meet their neighbours at creases (wall/wall,
  // wall/floor, box faces/table top, table edge/top), where the depth is continuous.
  // `shapesense-segdiag ceiling` merges the truth surfaces that touch along >= 150 step-free
  // pixel pairs of noise-free depth: that partition scores 0.77 on these seeds, so no step-only
  // criterion reaches 0.9; `shapesense-segdiag loss` lists the lost surfaces per seed (all merged
  // at creases, 0% unassigned). Variants measured (`shapesense-segdiag sweep`) stay within +-0.02
  // of the default:
  // noise_steps 2, min_threshold_mm 4, slope_factor 0.005 / 0.02, window radius 1 / 3, full
  // resolution, and a first-difference slope test (a step = a jump larger than 1.5-4x the
  // one-sided differences beside it; not kept). So the 0.9 is not asserted for depth_step;
  // the methods that also see creases are asserted above 0.9. Regression floors, about 0.02-0.03
  // below the values measured (seeds 1-6, frame 0): pixel accuracy depth_step 0.668, normal_edges
  // 0.936, fused 0.939, plane_prediction 0.945, tiled_ransac 0.950; correct fraction 0.19, 0.67,
  // 0.71, 0.67, 0.67.
  EXPECT_GE(accuracy[SegmentationMethod::kDepthStep], 0.65);
  EXPECT_GE(accuracy[SegmentationMethod::kNormalEdges], 0.92);
  EXPECT_GE(accuracy[SegmentationMethod::kFused], 0.92);
  EXPECT_GE(accuracy[SegmentationMethod::kPlanePrediction], 0.92);
  EXPECT_GE(accuracy[SegmentationMethod::kTiledRansac], 0.93);
  EXPECT_GE(correct[SegmentationMethod::kDepthStep], 0.16);
  EXPECT_GE(correct[SegmentationMethod::kNormalEdges], 0.64);
  EXPECT_GE(correct[SegmentationMethod::kFused], 0.68);
  EXPECT_GE(correct[SegmentationMethod::kPlanePrediction], 0.64);
  EXPECT_GE(correct[SegmentationMethod::kTiledRansac], 0.64);
  // Fusion must use both cues: fused at least as good as normal edges alone.
  EXPECT_GE(accuracy[SegmentationMethod::kFused],
            accuracy[SegmentationMethod::kNormalEdges] - 0.005);
}

}  // namespace
}  // namespace shapesense
