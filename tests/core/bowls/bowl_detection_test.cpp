// The shipped bowl models on held-out synthetic frames: scenes whose seeds were never used in
// training (training uses seed * 1000003 + scene for seeds 1 and, for evaluation, 9001; these
// use 424242 * 1000003 + k), evaluated with PASCAL VOC AP at IoU 0.5.
#include <filesystem>

#include <gtest/gtest.h>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

std::filesystem::path shippedModels() {
  return std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
}

// Goal: AP50 >= 0.95, measured by shapesense-train eval on the 160-frame test set (0.966) and
// two 800-frame sets (0.962, 0.970; models/README.md). These 16 frames hold only 19 bowls, so
// one bowl moves their AP by ~5 points: the floor sits below their measured 0.938.
constexpr double kApFloor = 0.88;

TEST(BowlDetection, HeldOutSyntheticFramesReachApFloor) {
  const auto detector = BowlDetector::load(shippedModels());
  HoughPlaneDetector plane_detector;
  std::vector<BowlEvalFrame> frames;
  for (int k = 0; k < 16; ++k) {
    synthetic::SceneParams p;
    p.seed = 424242ULL * 1000003ULL + static_cast<std::uint64_t>(k);
    p.render_colour = false;
    p.cups_min = 1;
    p.cups_max = 3;
    if (k % 2 == 1) {  // a raised camera: more "middle" views (the real frames' kind)
      p.camera_height_min_m = 1.3;
      p.camera_height_max_m = 1.6;
      p.table_distance_min_m = 1.1;
      p.table_distance_max_m = 1.8;
      p.min_table_elevation_deg = 17.0;
    }
    const synthetic::SyntheticScene scene(p);
    const auto r = scene.render(0, 0);
    BowlEvalFrame f;
    const auto& depth = r.frame.depth;
    f.detections =
        keepBowlShaped(detector.detect(depth, r.frame.intrinsics), depth, r.frame.intrinsics,
                       plane_detector.detect(depth, r.frame.intrinsics), {},
                       detector.operatingPoint().unverified_score_threshold);
    for (const auto& o : r.truth.objects)
      if (o.kind == "bowl" && o.upright && !o.image_box.empty())
        f.truth.push_back(
            {o.image_box, isDifficultBowl(o.image_box, o.pixel_count, o.visible_fraction)});
    frames.push_back(std::move(f));
  }
  const auto res = evaluateBowlDetections(frames, 0.5, 0.1);
  std::printf("held-out synthetic: %d bowls, AP50 %.3f, miss rate @0.1 FPPI %.3f, TP %d FP %d\n",
              res.positives, res.ap, res.miss_rate_at_fppi, res.true_positives,
              res.false_positives);
  ASSERT_GE(res.positives, 16);
  // Floor set below the shipped models' measured AP on these frames (kApFloor).
  EXPECT_GE(res.ap, kApFloor);
}

// Frames of any size, down to one pixel, one row or one column (a wrong camera.json, a cropped
// recording): no crash, and every box inside the frame.
TEST(BowlDetection, AnyFrameSize) {
  synthetic::SceneParams p;
  p.seed = 424242ULL * 1000003ULL + 97;
  p.render_colour = false;
  const auto r = synthetic::SyntheticScene(p).render(0, 0);
  BowlDetectorParams params;
  params.score_threshold = 0.0;  // many windows
  const auto detector = BowlDetector::load(shippedModels(), params);
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(2, 3), cv::Size(23, 12), cv::Size(24, 13), cv::Size(24, 22),
        cv::Size(30, 30), cv::Size(1, 480), cv::Size(640, 1), cv::Size(97, 41)}) {
    const cv::Point at(std::min(200, r.frame.depth.cols - size.width),
                       std::min(150, r.frame.depth.rows - size.height));
    const cv::Mat depth = r.frame.depth(cv::Rect(at, size)).clone();
    CameraIntrinsics k = r.frame.intrinsics;
    k.cx -= at.x;
    k.cy -= at.y;
    k.width = size.width;
    k.height = size.height;
    for (const auto& d : detector.detectRaw(depth, k))
      EXPECT_EQ(d.box & cv::Rect(cv::Point(0, 0), size), d.box) << size;
    EXPECT_NO_THROW(detector.detect(depth, k)) << size;
  }
}

TEST(BowlDetection, ParallelLevelsGiveTheSameDetections) {
  synthetic::SceneParams p;
  p.seed = 424242ULL * 1000003ULL + 99;
  p.render_colour = false;
  const auto r = synthetic::SyntheticScene(p).render(0, 0);
  BowlDetectorParams serial, parallel;
  parallel.parallel = true;
  serial.score_threshold = parallel.score_threshold = 0.0;  // many raw windows to compare
  const auto a =
      BowlDetector::load(shippedModels(), serial).detectRaw(r.frame.depth, r.frame.intrinsics);
  const auto b =
      BowlDetector::load(shippedModels(), parallel).detectRaw(r.frame.depth, r.frame.intrinsics);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].box, b[i].box);
    EXPECT_EQ(a[i].score, b[i].score);
    EXPECT_EQ(a[i].view, b[i].view);
  }
}

// Precomputed code images only change where a stage reads its LBP code, never the result; at
// the default stride 2 the first two stages also run in SIMD vectors, at stride 3 in the scalar
// loop, and neither changes it either.
TEST(BowlDetection, CodeImagesGiveTheSameWindowsAsTheIntegralImage) {
  synthetic::SceneParams p;
  p.seed = 424242ULL * 1000003ULL + 98;
  p.render_colour = false;
  const auto r = synthetic::SyntheticScene(p).render(0, 0);
  for (const int stride : {2, 3}) {
    BowlDetectorParams integral_only, some_codes, all_codes;
    integral_only.code_image_stages = 0;
    all_codes.code_image_stages = 1000;
    for (auto* params : {&integral_only, &some_codes, &all_codes}) {
      params->score_threshold = 0.0;  // many windows
      params->stride = stride;
    }
    const auto want = BowlDetector::load(shippedModels(), integral_only)
                          .detectRaw(r.frame.depth, r.frame.intrinsics);
    ASSERT_GT(want.size(), 10u);
    for (const auto* params : {&some_codes, &all_codes}) {
      const auto got =
          BowlDetector::load(shippedModels(), *params).detectRaw(r.frame.depth, r.frame.intrinsics);
      ASSERT_EQ(got.size(), want.size())
          << "stride " << stride << " code_image_stages " << params->code_image_stages;
      for (std::size_t i = 0; i < got.size(); ++i) {
        EXPECT_EQ(got[i].box, want[i].box);
        EXPECT_EQ(got[i].score, want[i].score);
        EXPECT_EQ(got[i].view, want[i].view);
      }
    }
  }
}

}  // namespace
}  // namespace shapesense
