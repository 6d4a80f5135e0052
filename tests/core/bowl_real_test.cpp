// The shipped bowl models on real Kinect-class frames (shared/data/real/mosd_tabletop): the
// two upright bowls (frames 5 and 6) are found at IoU >= 0.5 and frames 1-4 give no detection.
// These frames were never used for training; they are only this check (see the models' README).
// Skipped when shared/ is not there.
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/bowl_detector.h"
#include "shapesense/core/bowl_eval.h"
#include "shapesense/driver/tum_recording.h"
#include "test_paths.h"

namespace shapesense {
namespace {

std::filesystem::path shippedModels() {
  return std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
}

// x0 y0 x1 y1 inclusive, from shared/data/real/SOURCES.md.
cv::Rect inclusive(int x0, int y0, int x1, int y1) { return {x0, y0, x1 - x0 + 1, y1 - y0 + 1}; }

TEST(BowlReal, MosdUprightBowlsFoundNoFalsePositives) {
  const auto dir = testing::realRecording("mosd_tabletop");
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " missing";
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.depth.size(), 6u);
  const auto detector = BowlDetector::load(shippedModels());
  std::vector<std::vector<BowlDetection>> dets;
  for (const auto& e : index.depth) {
    const cv::Mat raw = cv::imread((dir / e.relative_path).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(raw.empty());
    cv::Mat mm;
    raw.convertTo(mm, CV_16UC1, 1000.0 / index.camera.depth_scale);
    dets.push_back(detector.detect(mm, index.camera.intrinsics));
  }
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(dets[i].empty()) << "frame " << i + 1 << ": " << dets[i].size()
                                 << " detections, first at "
                                 << (dets[i].empty() ? cv::Rect() : dets[i][0].box);
  }
  const cv::Rect truth5 = inclusive(55, 173, 151, 243), truth6 = inclusive(154, 125, 252, 197);
  const cv::Rect upside_down5 = inclusive(315, 114, 399, 187);
  auto best = [](const std::vector<BowlDetection>& d, const cv::Rect& t) {
    double b = 0;
    for (const auto& x : d) b = std::max(b, boxIoU(x.box, t));
    return b;
  };
  EXPECT_GE(best(dets[4], truth5), 0.5);
  EXPECT_GE(best(dets[5], truth6), 0.5);
  // Reported, not asserted: the upside-down bowl is not a bowl, and other windows on 5-6.
  std::printf(
      "frame 5: %zu detections, best IoU with the upright bowl %.2f, with the upside-down one "
      "%.2f\n",
      dets[4].size(), best(dets[4], truth5), best(dets[4], upside_down5));
  std::printf("frame 6: %zu detections, best IoU %.2f\n", dets[5].size(), best(dets[5], truth6));
}

}  // namespace
}  // namespace shapesense
