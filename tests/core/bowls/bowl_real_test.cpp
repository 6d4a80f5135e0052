// The shipped bowl detector (classifier + 3D check, default parameters) on every real
// Kinect-class recording in shared/data/real (85 frames). Requirement: every upright bowl is
// found at IoU >= 0.5 (mosd_tabletop frames 5 and 6, the only real bowls), and at most 2 false
// bowls are reported over all frames (any detection that is not one of those two bowls; the
// upside-down bowl of frame 5 is not a bowl to detect). The frames were never used for training
// or for choosing parameters; they are only this check (see models/README.md). Skipped when
// shared/ is not there.
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/tum_recording.h"
#include "test_paths.h"

namespace shapesense {
namespace {

constexpr int kMaxFalseBowls = 2;

std::filesystem::path shippedModels() {
  return std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
}

// x0 y0 x1 y1 inclusive, from shared/data/real/SOURCES.md.
cv::Rect inclusive(int x0, int y0, int x1, int y1) { return {x0, y0, x1 - x0 + 1, y1 - y0 + 1}; }

struct RealFrame {
  std::string name;
  std::vector<BowlDetection> detections;
};

std::vector<RealFrame> detectAll(const BowlDetector& detector, HoughPlaneDetector& plane_detector,
                                 const std::string& recording) {
  const auto dir = testing::realRecording(recording);
  const TumIndex index = readTumIndex(dir);
  std::vector<RealFrame> frames;
  for (const auto& e : index.depth) {
    const cv::Mat raw = cv::imread((dir / e.relative_path).string(), cv::IMREAD_UNCHANGED);
    EXPECT_FALSE(raw.empty()) << e.relative_path;
    if (raw.empty()) continue;
    cv::Mat mm;
    raw.convertTo(mm, CV_16UC1, 1000.0 / index.camera.depth_scale);
    const auto& intrinsics = index.camera.intrinsics;
    const auto planes = plane_detector.detect(mm, intrinsics);
    frames.push_back({recording + "/" + e.relative_path.string(),
                      keepBowlShaped(detector.detect(mm, intrinsics), mm, intrinsics, planes, {},
                                     detector.operatingPoint().unverified_score_threshold)});
  }
  return frames;
}

TEST(BowlReal, EveryUprightBowlFoundAtMostTwoFalseOnAllRealFrames) {
  if (!std::filesystem::exists(testing::realRecording("mosd_tabletop")))
    GTEST_SKIP() << "shared/data/real missing";
  const auto detector = BowlDetector::load(shippedModels());
  HoughPlaneDetector plane_detector;
  // Upright bowls by recording and frame index (0-based), from SOURCES.md.
  const std::vector<std::pair<std::string, std::vector<std::pair<std::size_t, cv::Rect>>>>
      recordings = {
          {"mosd_tabletop",
           {{4, inclusive(55, 173, 151, 243)}, {5, inclusive(154, 125, 252, 197)}}},
          {"mosd_learn", {}},
          {"mosd_test", {}},
          {"pcl_room_sweep", {}},
          {"pcl_desk_sequence", {}},
          {"pcl_office", {}},
          {"pcl_tabletop_milk", {}},
          {"tum_fr2_desk", {}},
          {"cape_room", {}},
      };
  int frames_seen = 0, false_bowls = 0, bowls_found = 0, bowls_total = 0;
  std::string false_list;
  for (const auto& [recording, truth] : recordings) {
    const auto frames = detectAll(detector, plane_detector, recording);
    frames_seen += static_cast<int>(frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const cv::Rect* bowl = nullptr;
      for (const auto& [index, box] : truth)
        if (index == i) bowl = &box;
      bool found = false;
      for (const auto& d : frames[i].detections) {
        if (bowl != nullptr && boxIoU(d.box, *bowl) >= 0.5) {
          found = true;
          ASSERT_TRUE(d.geometry.has_value());
          // A real bowl of these frames has a rim of 15-25 cm: the measurement is a bowl's.
          EXPECT_GT(d.geometry->rim_diameter_m, 0.08) << frames[i].name;
          EXPECT_LT(d.geometry->rim_diameter_m, 0.35) << frames[i].name;
          continue;
        }
        ++false_bowls;
        std::ostringstream line;
        line << "\n  " << frames[i].name << " at " << d.box << " score " << d.score;
        false_list += line.str();
      }
      if (bowl != nullptr) {
        ++bowls_total;
        bowls_found += found;
        EXPECT_TRUE(found) << "upright bowl missed on " << frames[i].name;
      }
    }
  }
  EXPECT_EQ(frames_seen, 85);
  EXPECT_EQ(bowls_found, bowls_total);
  EXPECT_EQ(bowls_total, 2);
  EXPECT_LE(false_bowls, kMaxFalseBowls) << "false bowls:" << false_list;
  std::printf("%d false bowls on %d frames:%s\n", false_bowls, frames_seen, false_list.c_str());
}

}  // namespace
}  // namespace shapesense
