// PngCache: a frame's image is encoded once however many calls ask for it, and what comes back
// decodes to the image.

#include "shapesense/server/png_cache.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

cv::Mat depthImage(int seed) {
  cv::Mat depth(48, 64, CV_16UC1);
  cv::randu(depth, cv::Scalar(500 + seed), cv::Scalar(4000));
  return depth;
}

cv::Mat decoded(const std::string& png) {
  const std::vector<unsigned char> bytes(png.begin(), png.end());
  return cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
}

TEST(PngCache, DecodesToTheImage) {
  PngCache cache;
  const cv::Mat depth = depthImage(0);
  const auto png = cache.get(1, 100, FrameImage::kDepth, depth);
  const cv::Mat back = decoded(*png);
  ASSERT_EQ(back.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(back, depth, cv::NORM_INF), 0.0);
}

TEST(PngCache, TheSameImageOfTheSameFrameIsEncodedOnce) {
  PngCache cache;
  const cv::Mat depth = depthImage(0);
  const auto first = cache.get(1, 100, FrameImage::kDepth, depth);
  EXPECT_EQ(cache.get(1, 100, FrameImage::kDepth, depth), first);
  // Another kind, another frame, or the same sequence with another capture time (a restarted
  // replay) is another image.
  EXPECT_NE(cache.get(1, 100, FrameImage::kPlaneLabels, depth), first);
  EXPECT_NE(cache.get(2, 133, FrameImage::kDepth, depth), first);
  EXPECT_NE(cache.get(1, 999, FrameImage::kDepth, depth), first);
}

TEST(PngCache, KeepsTheImagesAskedForMostRecently) {
  PngCache cache;
  const cv::Mat depth = depthImage(0);
  const auto kept = cache.get(0, 0, FrameImage::kDepth, depth);
  const auto dropped = cache.get(1, 1, FrameImage::kDepth, depth);
  for (std::uint64_t frame = 2; frame < PngCache::kEntries + 1; ++frame) {
    cache.get(frame, static_cast<std::int64_t>(frame), FrameImage::kDepth, depth);
    EXPECT_EQ(cache.get(0, 0, FrameImage::kDepth, depth), kept);  // asked for again and again
  }
  // kEntries + 1 images were asked for: frame 1's was the least recently used.
  EXPECT_EQ(cache.get(0, 0, FrameImage::kDepth, depth), kept);
  EXPECT_NE(cache.get(1, 1, FrameImage::kDepth, depth), dropped);
}

}  // namespace
}  // namespace shapesense
