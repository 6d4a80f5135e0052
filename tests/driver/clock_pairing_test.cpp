// DepthColourPairer: depth images are paired with the colour image nearest in capture time,
// waiting for a later colour image when that one may be nearer.

#include "shapesense/driver/live_sources_pairing.h"

#include <gtest/gtest.h>

namespace shapesense {
namespace {

constexpr TimestampNs kMs = 1'000'000;

StampedImage image(int tag, TimestampNs t_ms) {
  return {cv::Mat(1, 1, CV_16UC1, cv::Scalar(tag)), t_ms * kMs};
}
int tagOf(const cv::Mat& m) { return m.empty() ? -1 : m.at<std::uint16_t>(0, 0); }

TEST(DepthColourPairer, WaitsForALaterColourImageAndPicksTheNearest) {
  DepthColourPairer pairer;
  EXPECT_TRUE(pairer.addColour(image(1, 0)).empty());
  // Depth at 12 ms: colour 1 (0 ms) is 12 ms away, a later one may be nearer.
  EXPECT_TRUE(pairer.addDepth(image(100, 12)).empty());
  EXPECT_EQ(pairer.pendingDepth(), 1u);
  const auto out = pairer.addColour(image(2, 33));  // 21 ms away: colour 1 wins
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(tagOf(out[0].depth.image), 100);
  EXPECT_EQ(out[0].depth.capture_ns, 12 * kMs);
  EXPECT_EQ(tagOf(out[0].colour), 1);

  EXPECT_TRUE(pairer.addDepth(image(101, 45)).empty());
  const auto next = pairer.addColour(image(3, 50));  // 5 ms after: nearer than colour 2 (12 ms)
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(tagOf(next[0].colour), 3);
}

TEST(DepthColourPairer, ReleasesUnpairedWhenNoColourIsCloseEnough) {
  DepthColourPairer pairer;
  pairer.addColour(image(1, 0));
  EXPECT_TRUE(pairer.addDepth(image(100, 40)).empty());  // 40 ms from colour 1: too far
  const auto out = pairer.addDepth(image(101, 73));      // newest is 33 ms > 20 ms newer
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(tagOf(out[0].depth.image), 100);
  EXPECT_TRUE(out[0].colour.empty());
  EXPECT_EQ(pairer.pendingDepth(), 1u);
  const auto flushed = pairer.flush();
  ASSERT_EQ(flushed.size(), 1u);
  EXPECT_EQ(tagOf(flushed[0].depth.image), 101);
}

TEST(DepthColourPairer, KeepsDepthOrderAndBoundsWhatItHolds) {
  PairingParams params;
  params.max_offset = std::chrono::milliseconds(1000);  // nothing ever gets "too old"
  params.max_pending_depth = 2;
  DepthColourPairer pairer(params);
  std::vector<int> released;
  for (int i = 0; i < 6; ++i) {
    for (auto& p : pairer.addDepth(image(i, i))) released.push_back(tagOf(p.depth.image));
  }
  EXPECT_EQ(released, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(pairer.pendingDepth(), 2u);
  pairer.reset();
  EXPECT_EQ(pairer.pendingDepth(), 0u);
  EXPECT_TRUE(pairer.flush().empty());
}

TEST(DepthColourPairer, SameStampPairsAtOnce) {
  DepthColourPairer pairer;
  EXPECT_TRUE(pairer.addDepth(image(100, 10)).empty());
  const auto out = pairer.addColour(image(7, 10));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(tagOf(out[0].colour), 7);
  // Colour first, depth at the same stamp: released immediately.
  pairer.addColour(image(8, 43));
  const auto second = pairer.addDepth(image(101, 43));
  ASSERT_EQ(second.size(), 1u);
  EXPECT_EQ(tagOf(second[0].colour), 8);
}

}  // namespace
}  // namespace shapesense
