// Segmentation accuracy against the synthetic renderer's ground truth (one label per planar face
// or curved object). Figures are printed; thresholds sit slightly below what each method reached
// when written (see the printed table), depth-step's pixel accuracy at the 0.9 requirement.
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "shapesense/core/segmentation.h"
#include "shapesense/core/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

TEST(SegmentationSynthetic, SegCompAgainstSurfaceLabels) {
  const SegmentationMethod methods[] = {SegmentationMethod::kDepthStep, SegmentationMethod::kNormalEdges,
                                        SegmentationMethod::kFused, SegmentationMethod::kPlanePrediction,
                                        SegmentationMethod::kTiledRansac};
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
      std::printf("[seg synthetic] seed %llu %-16s correct %2d/%2d (%.2f) over %d under %d missed %d  pixel acc %.3f\n",
                  static_cast<unsigned long long>(seed), std::string(formatSegmentationMethod(m)).c_str(),
                  s.correct, s.truth_regions, s.correct_fraction, s.over_segmented, s.under_segmented, s.missed,
                  s.pixel_accuracy);
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
  // The stated requirement (not met at the time of writing: 0.66, see the report; depth steps
  // alone cannot split faces that meet at creases, which the per-face truth counts).
  EXPECT_GE(accuracy[SegmentationMethod::kDepthStep], 0.9);
  // Regression floors, slightly below the values measured when written (seeds 1-6, frame 0).
  EXPECT_GE(accuracy[SegmentationMethod::kNormalEdges], 0.74);
  EXPECT_GE(accuracy[SegmentationMethod::kFused], 0.74);
  EXPECT_GE(accuracy[SegmentationMethod::kPlanePrediction], 0.72);
  EXPECT_GE(accuracy[SegmentationMethod::kTiledRansac], 0.92);
  EXPECT_GE(correct[SegmentationMethod::kTiledRansac], 0.58);
  EXPECT_GE(correct[SegmentationMethod::kPlanePrediction], 0.22);
}

}  // namespace
}  // namespace shapesense
