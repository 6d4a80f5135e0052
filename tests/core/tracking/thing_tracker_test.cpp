#include "shapesense/core/tracking/thing_tracker.h"

#include <random>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

/// An axis-aligned box of side `size` (m) centred at `centre`, in BoxCorners order.
BoxCorners cubeAt(const Eigen::Vector3d& centre, double size) {
  const double h = size / 2;
  const Eigen::Vector3d ftl = centre + Eigen::Vector3d(-h, -h, -h);
  BoxCorners corners;
  const double dx[4] = {0, 1, 1, 0};
  const double dy[4] = {0, 0, 1, 1};
  for (int face = 0; face < 2; ++face) {
    for (int i = 0; i < 4; ++i) {
      corners[face * 4 + i] = ftl + Eigen::Vector3d(dx[i] * size, dy[i] * size, face * size);
    }
  }
  return corners;
}

ThingObservation bowlAt(const Eigen::Vector3d& centre, double score = 40) {
  return {ThingKind::kBowl, cubeAt(centre, 0.15), cv::Rect(100, 100, 50, 40), score};
}

ThingObservation objectAt(const Eigen::Vector3d& centre) {
  return {ThingKind::kObject, cubeAt(centre, 0.10), cv::Rect(200, 120, 30, 30), 0.0};
}

const Eigen::Vector3d kA(0.1, 0.2, 1.5);
const Eigen::Vector3d kB(-0.4, 0.2, 1.8);

TEST(ThingTracker, ReportsAThingOnlyAfterConfirmFramesConsecutiveSightings) {
  ThingTracker tracker;  // confirm_frames = 3
  EXPECT_TRUE(tracker.update({bowlAt(kA)}).empty());
  EXPECT_TRUE(tracker.update({bowlAt(kA)}).empty());
  const auto things = tracker.update({bowlAt(kA)});
  ASSERT_EQ(things.size(), 1u);
  EXPECT_EQ(things[0].id, 1u);
  EXPECT_EQ(things[0].kind, ThingKind::kBowl);
  EXPECT_EQ(things[0].frames_seen, 3u);
  EXPECT_EQ(things[0].frames_missed, 0u);
}

TEST(ThingTracker, ADetectionThatComesAndGoesIsNeverReported) {
  ThingTracker tracker;
  for (int frame = 0; frame < 40; ++frame) {
    std::vector<ThingObservation> observations = {objectAt(kB)};
    // A false bowl seen in two of every three frames never gets three in a row.
    if (frame % 3 != 2) observations.push_back(bowlAt(kA));
    const auto things = tracker.update(observations);
    for (const auto& thing : things) EXPECT_EQ(thing.kind, ThingKind::kObject) << frame;
  }
}

TEST(ThingTracker, KeepsAConfirmedThingThroughAGapWithTheSameId) {
  ThingTrackerParams params;
  params.keep_frames = 4;
  ThingTracker tracker(params);
  for (int i = 0; i < 5; ++i) tracker.update({bowlAt(kA)});
  for (std::uint32_t missed = 1; missed <= 4; ++missed) {
    const auto things = tracker.update({});
    ASSERT_EQ(things.size(), 1u) << missed;
    EXPECT_EQ(things[0].frames_missed, missed);
    EXPECT_NEAR((boxCentre(things[0].corners) - kA).norm(), 0.0, 1e-9);
  }
  const auto back = tracker.update({bowlAt(kA)});
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].id, 1u);
  EXPECT_EQ(back[0].frames_missed, 0u);
}

TEST(ThingTracker, DropsAThingMissedForLongerThanKeepFrames) {
  ThingTrackerParams params;
  params.keep_frames = 2;
  ThingTracker tracker(params);
  for (int i = 0; i < 5; ++i) tracker.update({bowlAt(kA)});
  EXPECT_EQ(tracker.update({}).size(), 1u);
  EXPECT_EQ(tracker.update({}).size(), 1u);
  EXPECT_TRUE(tracker.update({}).empty());
  // It comes back as a new thing, confirmed again and with a new id.
  tracker.update({bowlAt(kA)});
  tracker.update({bowlAt(kA)});
  const auto again = tracker.update({bowlAt(kA)});
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].id, 2u);
}

TEST(ThingTracker, FollowsASlowlyMovingThingAndSplitsOnAJump) {
  ThingTracker tracker;
  Eigen::Vector3d centre = kA;
  std::uint32_t id = 0;
  for (int frame = 0; frame < 20; ++frame) {
    centre.x() += 0.01;  // 1 cm a frame: within the gate of a 15 cm box
    const auto things = tracker.update({bowlAt(centre)});
    if (frame < 2) continue;
    ASSERT_EQ(things.size(), 1u) << frame;
    if (id == 0) id = things[0].id;
    EXPECT_EQ(things[0].id, id) << frame;
  }
  // Half a metre away is another bowl: the old one is kept through its gap, the new one waits
  // for its confirmation.
  const Eigen::Vector3d far = centre + Eigen::Vector3d(0.5, 0, 0);
  EXPECT_EQ(tracker.update({bowlAt(far)}).size(), 1u);
  tracker.update({bowlAt(far)});
  const auto things = tracker.update({bowlAt(far)});
  ASSERT_EQ(things.size(), 2u);
  EXPECT_EQ(things[0].id, id);
  EXPECT_EQ(things[0].frames_missed, 3u);
  EXPECT_NE(things[1].id, id);
}

TEST(ThingTracker, KindsAreTrackedApart) {
  ThingTracker tracker;
  for (int i = 0; i < 3; ++i) tracker.update({bowlAt(kA), objectAt(kA)});
  const auto things = tracker.update({bowlAt(kA), objectAt(kA)});
  ASSERT_EQ(things.size(), 2u);
  EXPECT_NE(things[0].kind, things[1].kind);
}

TEST(ThingTracker, SmoothingHalvesTheJitterOfAStaticThing) {
  // Requirement: a static thing's reported box jitters less than its detections (noise std
  // 1 cm per coordinate; with smoothing 0.5 the reported centre's std is 1/sqrt(3) of it).
  ThingTracker tracker;
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  double raw_sum = 0, smoothed_sum = 0;
  int n = 0;
  for (int frame = 0; frame < 400; ++frame) {
    const Eigen::Vector3d seen = kA + Eigen::Vector3d(noise(random), noise(random), noise(random));
    const auto things = tracker.update({bowlAt(seen)});
    if (frame < 20) continue;
    ASSERT_EQ(things.size(), 1u);
    raw_sum += (seen - kA).squaredNorm();
    smoothed_sum += (boxCentre(things[0].corners) - kA).squaredNorm();
    ++n;
  }
  EXPECT_LT(std::sqrt(smoothed_sum / n), 0.7 * std::sqrt(raw_sum / n));
}

TEST(ThingTracker, AStrongerObservationKeepsTheTrackOverAWeakDuplicate) {
  ThingTracker tracker;
  for (int i = 0; i < 4; ++i) tracker.update({bowlAt(kA, 60)});
  const Eigen::Vector3d beside = kA + Eigen::Vector3d(0.03, 0, 0);
  const auto things = tracker.update({bowlAt(beside, 15), bowlAt(kA, 60)});
  ASSERT_EQ(things.size(), 1u);
  EXPECT_DOUBLE_EQ(things[0].score, 60);
}

}  // namespace
}  // namespace shapesense
