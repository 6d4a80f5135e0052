// GetFrame through a real in-process gRPC server: images decode back exactly, and the lookup
// rule and error codes of the API contract.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "server_fixture.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/pipeline/stages.h"

namespace shapesense {
namespace {

using testing::clientContext;
using ::testing::HasSubstr;
using testing::kFramePeriodNs;
using testing::kServerT0;
using testing::ServerTest;

bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  if (a.empty()) return true;
  cv::Mat diff;
  cv::compare(a.reshape(1), b.reshape(1), diff, cv::CMP_NE);
  return cv::countNonZero(diff) == 0;
}

cv::Mat decode(const std::string& png, int flags) {
  std::vector<unsigned char> bytes(png.begin(), png.end());
  return cv::imdecode(bytes, flags);
}

class GetFrameTest : public ServerTest {
 protected:
  grpc::Status get(std::int64_t at_ns, v1::GetFrameResponse& response, bool skip_depth = false,
                   bool skip_rgb = false) {
    v1::GetFrameRequest request;
    request.set_at_ns(at_ns);
    request.set_skip_depth(skip_depth);
    request.set_skip_rgb(skip_rgb);
    auto context = clientContext();
    return srv.stub().GetFrame(context.get(), request, &response);
  }

  std::uint64_t sequenceAt(std::int64_t at_ns) {
    v1::GetFrameResponse response;
    const grpc::Status status = get(at_ns, response, true, true);
    EXPECT_TRUE(status.ok()) << "T=" << at_ns << ": " << status.error_message();
    return response.info().sequence();
  }

  static std::int64_t t(int i) { return kServerT0 + i * kFramePeriodNs; }
};

TEST_F(GetFrameTest, PngsDecodeToTheExactDepthAndColour) {
  srv.addMany(3);
  const Frame& expected = *srv.added()[1];
  v1::GetFrameResponse response;
  const grpc::Status status = get(t(1), response);
  ASSERT_TRUE(status.ok()) << status.error_message();

  const cv::Mat depth = decode(response.depth_png(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth.type(), CV_16UC1) << "depth PNG must be 16-bit grey";
  EXPECT_TRUE(identical(depth, expected.depth));
  EXPECT_EQ(depth.at<std::uint16_t>(0, 0), 0u);
  EXPECT_EQ(depth.at<std::uint16_t>(1, 0), 13107u);

  // OpenCV decodes to BGR, as the frame holds it; the file itself is RGB.
  const cv::Mat rgb = decode(response.rgb_png(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(rgb.type(), CV_8UC3);
  EXPECT_TRUE(identical(rgb, expected.rgb));

  EXPECT_EQ(response.info().sequence(), 1u);
  EXPECT_EQ(response.info().timestamp_ns(), t(1));
  EXPECT_EQ(response.info().width(), 32u);
  EXPECT_EQ(response.info().height(), 24u);
  EXPECT_TRUE(response.info().has_rgb());
  EXPECT_TRUE(response.info().processed());
  EXPECT_DOUBLE_EQ(response.intrinsics().fx(), expected.intrinsics.fx);
  EXPECT_DOUBLE_EQ(response.intrinsics().fy(), expected.intrinsics.fy);
  EXPECT_DOUBLE_EQ(response.intrinsics().cx(), expected.intrinsics.cx);
  EXPECT_DOUBLE_EQ(response.intrinsics().cy(), expected.intrinsics.cy);
  EXPECT_EQ(response.intrinsics().width(), 32u);
  EXPECT_EQ(response.intrinsics().height(), 24u);

  ASSERT_TRUE(response.has_depth_stats());
  const DepthStatistics stats = computeDepthStatistics(expected.depth);
  EXPECT_DOUBLE_EQ(response.depth_stats().valid_fraction(), stats.valid_fraction);
  EXPECT_DOUBLE_EQ(response.depth_stats().min_m(), stats.min_m);
  EXPECT_DOUBLE_EQ(response.depth_stats().median_m(), stats.median_m);
  EXPECT_DOUBLE_EQ(response.depth_stats().max_m(), 13.107);
}

TEST_F(GetFrameTest, RgbPngIsRgbOrderOnTheWire) {
  // A pure blue frame (BGR 255,0,0) must not come back red (channel order swapped on the way).
  auto frame = std::make_shared<Frame>(testing::makeTestFrame(t(0), 0, true, 4, 4));
  frame->rgb.setTo(cv::Scalar(255, 0, 0));
  ASSERT_TRUE(srv.cache().insert(frame));
  v1::GetFrameResponse response;
  ASSERT_TRUE(get(0, response).ok());
  const cv::Mat bgr = decode(response.rgb_png(), cv::IMREAD_COLOR);
  ASSERT_FALSE(bgr.empty());
  // OpenCV's PNG reader turns the file's RGB into BGR: blue comes back as blue.
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 0, 0));
}

TEST_F(GetFrameTest, SkipDepthAndSkipRgb) {
  srv.addMany(2);
  v1::GetFrameResponse response;
  ASSERT_TRUE(get(0, response, /*skip_depth=*/true, /*skip_rgb=*/false).ok());
  EXPECT_TRUE(response.depth_png().empty());
  EXPECT_FALSE(response.rgb_png().empty());
  response.Clear();
  ASSERT_TRUE(get(0, response, false, true).ok());
  EXPECT_FALSE(response.depth_png().empty());
  EXPECT_TRUE(response.rgb_png().empty());
  EXPECT_TRUE(response.info().has_rgb());  // the frame has colour, it just was not sent
}

TEST_F(GetFrameTest, FrameWithoutColourOrResults) {
  srv.add(t(0), /*with_rgb=*/false, /*publish_results=*/false);
  v1::GetFrameResponse response;
  ASSERT_TRUE(get(0, response).ok());
  EXPECT_TRUE(response.rgb_png().empty());
  EXPECT_FALSE(response.info().has_rgb());
  EXPECT_FALSE(response.info().processed());
  EXPECT_FALSE(response.has_depth_stats());
  EXPECT_TRUE(identical(decode(response.depth_png(), cv::IMREAD_UNCHANGED), srv.added()[0]->depth));
}

TEST_F(GetFrameTest, LookupRuleAtTheEdges) {
  srv.addMany(5);  // frames 0..4
  for (int i = 0; i < 5; ++i) EXPECT_EQ(sequenceAt(t(i)), static_cast<std::uint64_t>(i));  // exact
  EXPECT_EQ(sequenceAt(t(2) + 1), 2u);  // between: the earlier
  EXPECT_EQ(sequenceAt(t(3) - 1), 2u);
  EXPECT_EQ(sequenceAt(t(2) + kFramePeriodNs / 2), 2u);
  EXPECT_EQ(sequenceAt(t(4) + 1), 4u);  // after the newest: the newest
  EXPECT_EQ(sequenceAt(t(4) + 3'600'000'000'000LL), 4u);
  EXPECT_EQ(sequenceAt(0), 4u);  // 0: the newest
}

TEST_F(GetFrameTest, BeforeTheCacheIsOutOfRangeNamingTheRange) {
  srv.addMany(5);
  for (std::int64_t at : {t(0) - 1, t(0) - 1'000'000'000, std::int64_t{1}}) {
    v1::GetFrameResponse response;
    const grpc::Status status = get(at, response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::OUT_OF_RANGE) << at;
    EXPECT_THAT(status.error_message(), HasSubstr(formatNsAsSeconds(t(0))));
    EXPECT_THAT(status.error_message(), HasSubstr(formatNsAsSeconds(t(4))));
  }
}

TEST_F(GetFrameTest, EvictedTimeIsOutOfRange) {
  testing::TestServer small(3);
  small.addMany(6);  // frames 3..5 remain
  v1::GetFrameRequest request;
  request.set_at_ns(t(1));
  v1::GetFrameResponse response;
  auto context = clientContext();
  const grpc::Status status = small.stub().GetFrame(context.get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_THAT(status.error_message(), HasSubstr(formatNsAsSeconds(t(3))));
  EXPECT_THAT(status.error_message(), HasSubstr(formatNsAsSeconds(t(5))));
}

TEST_F(GetFrameTest, EmptyCacheIsUnavailable) {
  for (std::int64_t at : {std::int64_t{0}, t(0)}) {
    v1::GetFrameResponse response;
    const grpc::Status status = get(at, response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << at;
    EXPECT_FALSE(status.error_message().empty());
  }
}

TEST_F(GetFrameTest, NegativeTimeIsInvalidArgument) {
  srv.addMany(2);
  for (std::int64_t at : {std::int64_t{-1}, -t(1)}) {
    v1::GetFrameResponse response;
    EXPECT_EQ(get(at, response).error_code(), grpc::StatusCode::INVALID_ARGUMENT) << at;
  }
  // Also on an empty cache: the request itself is malformed.
  testing::TestServer empty(2);
  v1::GetFrameRequest request;
  request.set_at_ns(-1);
  v1::GetFrameResponse response;
  auto context = clientContext();
  EXPECT_EQ(empty.stub().GetFrame(context.get(), request, &response).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(GetFrameTest, FullSizeKinectFrameRoundTrips) {
  auto frame = std::make_shared<Frame>(testing::makeTestFrame(t(0), 0, true, 640, 480));
  ASSERT_TRUE(srv.cache().insert(frame));
  v1::GetFrameResponse response;
  ASSERT_TRUE(get(t(0), response).ok());
  EXPECT_TRUE(identical(decode(response.depth_png(), cv::IMREAD_UNCHANGED), frame->depth));
  EXPECT_TRUE(identical(decode(response.rgb_png(), cv::IMREAD_UNCHANGED), frame->rgb));
}

}  // namespace
}  // namespace shapesense
