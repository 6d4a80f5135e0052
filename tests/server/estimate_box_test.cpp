// EstimateBox through a real in-process gRPC server: geometry against synthetic ground truth,
// the cache lookup rule at its edges, and every error status the API promises.

#include <gtest/gtest.h>

#include "server_fixture.h"
#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::testing {
namespace {

class EstimateBoxTest : public ::testing::Test {
 protected:
  void SetUp() override {
    synthetic::SceneParams params;
    params.seed = 3;
    params.render_colour = false;
    const synthetic::SyntheticScene scene(params);
    for (int i = 0; i < 3; ++i) {
      auto rendered = scene.render(i, kServerT0 + i * kFramePeriodNs);
      rendered.frame.sequence = i;
      truths.push_back(rendered.truth);
      ASSERT_TRUE(srv.cache().insert(std::make_shared<const Frame>(std::move(rendered.frame))));
    }
  }

  grpc::Status call(std::int64_t at_ns, cv::Point p1, cv::Point p2, int mode,
                    v1::EstimateBoxResponse& response) {
    v1::EstimateBoxRequest request;
    request.set_at_ns(at_ns);
    request.mutable_p1()->set_x(p1.x);
    request.mutable_p1()->set_y(p1.y);
    request.mutable_p2()->set_x(p2.x);
    request.mutable_p2()->set_y(p2.y);
    request.set_mode(static_cast<v1::BoxMode>(mode));
    return srv.stub().EstimateBox(clientContext().get(), request, &response);
  }

  // The first non-table object of frame `i` with enough visible pixels.
  const synthetic::TruthObject& someObject(int i) {
    for (const auto& object : truths[i].objects) {
      if (object.kind != "table" && object.pixel_count > 800) return object;
    }
    ADD_FAILURE() << "no visible object";
    return truths[i].objects.front();
  }

  // Share of the object's measured points of frame `sequence` inside the response's box, with
  // `tolerance_m` of slack: the same test the core suite makes, here after the wire.
  double shareInside(const v1::EstimateBoxResponse& response, int sequence,
                     const synthetic::TruthObject& object, double tolerance_m) {
    BoxCorners corners;
    for (int i = 0; i < 8; ++i)
      corners[i] = {response.corners(i).x(), response.corners(i).y(), response.corners(i).z()};
    const Frame& frame = *srv.cache().bySequence(sequence)->frame;
    const cv::Rect r = object.image_box;
    int inside = 0, total = 0;
    for (int v = r.y; v < r.y + r.height; ++v) {
      for (int u = r.x; u < r.x + r.width; ++u) {
        if (truths[sequence].object_labels.at<std::uint16_t>(v, u) != object.id) continue;
        const double z = frame.depth.at<std::uint16_t>(v, u) * 1e-3;
        ++total;
        inside += boxContains(corners, frame.intrinsics.backproject(u, v, z), tolerance_m);
      }
    }
    return total ? static_cast<double>(inside) / total : 0.0;
  }

  TestServer srv;
  std::vector<synthetic::TruthFrame> truths;
};

TEST_F(EstimateBoxTest, Mode2BoxContainsMostOfTheObject) {
  const auto& object = someObject(1);
  const cv::Rect r = object.image_box;
  v1::EstimateBoxResponse response;
  const auto status =
      call(kServerT0 + kFramePeriodNs, r.tl(), r.br() - cv::Point(1, 1), 2, response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.corners_size(), 8);
  EXPECT_EQ(response.frame_timestamp_ns(), kServerT0 + kFramePeriodNs);
  EXPECT_EQ(response.frame_sequence(), 1u);
  EXPECT_EQ(response.mode(), v1::BOX_MODE_AXIS_ALIGNED_CONTAINED);
  EXPECT_GT(response.stats().used_pixels(), 0u);
  EXPECT_LE(response.stats().used_pixels(), response.stats().valid_pixels());
  // Mode 2's geometry caps containment below 1 (see box_estimation_synthetic_test.cpp).
  EXPECT_GE(shareInside(response, 1, object, 0.005), 0.6) << object.name;
}

TEST_F(EstimateBoxTest, EveryModeAnswersAndUnspecifiedMeansMode1) {
  const cv::Rect r = someObject(2).image_box;
  v1::EstimateBoxResponse unspecified, mode1;
  ASSERT_TRUE(call(0, r.tl(), r.br() - cv::Point(1, 1), 0, unspecified).ok());
  ASSERT_TRUE(call(0, r.tl(), r.br() - cv::Point(1, 1), 1, mode1).ok());
  EXPECT_EQ(unspecified.mode(), v1::BOX_MODE_FRUSTUM_ALIGNED);
  for (int i = 0; i < 8; ++i) EXPECT_DOUBLE_EQ(unspecified.corners(i).z(), mode1.corners(i).z());
  EXPECT_TRUE(mode1.stats().range_from_origin());
  v1::EstimateBoxResponse mode3;
  ASSERT_TRUE(call(0, r.tl(), r.br() - cv::Point(1, 1), 3, mode3).ok());
  EXPECT_FALSE(mode3.stats().range_from_origin());
  // Mode 3: the front face is a fronto-parallel rectangle at the near depth.
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(mode3.corners(i).z(), mode3.stats().near_m(), 1e-9);
}

TEST_F(EstimateBoxTest, UsesTheLatestFrameAtOrBeforeT) {
  const cv::Point p1(300, 200), p2(340, 240);
  v1::EstimateBoxResponse response;
  ASSERT_TRUE(
      call(kServerT0 + 2 * kFramePeriodNs, p1, p2, 1, response).ok());  // exactly on frame 2
  EXPECT_EQ(response.frame_sequence(), 2u);
  ASSERT_TRUE(
      call(kServerT0 + kFramePeriodNs + 1000, p1, p2, 1, response).ok());  // between 1 and 2
  EXPECT_EQ(response.frame_sequence(), 1u);
  ASSERT_TRUE(
      call(kServerT0 + 100 * kFramePeriodNs, p1, p2, 1, response).ok());  // after the newest
  EXPECT_EQ(response.frame_sequence(), 2u);
  ASSERT_TRUE(call(0, p1, p2, 1, response).ok());  // 0 = the newest
  EXPECT_EQ(response.frame_sequence(), 2u);
}

TEST_F(EstimateBoxTest, TimeBeforeTheCacheIsOutOfRangeNamingTheRange) {
  v1::EstimateBoxResponse response;
  const auto status = call(kServerT0 - 1, {300, 200}, {340, 240}, 1, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_NE(status.error_message().find("1700000000.000000"), std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("3 frames"), std::string::npos) << status.error_message();
}

TEST_F(EstimateBoxTest, RoiOutsideTheImageIsInvalidArgument) {
  v1::EstimateBoxResponse response;
  for (auto [p1, p2] : {std::pair{cv::Point(600, 400), cv::Point(700, 470)},     // partly outside
                        std::pair{cv::Point(-5, 10), cv::Point(20, 30)},         // negative
                        std::pair{cv::Point(650, 500), cv::Point(700, 520)}}) {  // wholly outside
    const auto status = call(0, p1, p2, 2, response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << p1 << p2;
    EXPECT_NE(status.error_message().find("640x480"), std::string::npos) << status.error_message();
  }
}

TEST_F(EstimateBoxTest, MissingCornersAndUnknownModeAreInvalidArgument) {
  v1::EstimateBoxRequest request;  // an empty ROI: no corners at all
  v1::EstimateBoxResponse response;
  auto status = srv.stub().EstimateBox(clientContext().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("p1 and p2"), std::string::npos);
  status = call(0, {300, 200}, {340, 240}, 7, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("mode 7"), std::string::npos);
}

TEST_F(EstimateBoxTest, RoiWithoutDepthIsFailedPrecondition) {
  // A frame whose depth is all zero in its top-left corner.
  Frame frame = *srv.cache().bySequence(2)->frame;
  frame.depth = frame.depth.clone();
  frame.depth(cv::Rect(0, 0, 50, 50)).setTo(0);
  frame.timestamp_ns = kServerT0 + 3 * kFramePeriodNs;
  frame.sequence = 3;
  ASSERT_TRUE(srv.cache().insert(std::make_shared<const Frame>(frame)));
  v1::EstimateBoxResponse response;
  const auto status = call(0, {5, 5}, {40, 40}, 1, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

// Mode 4 boxes the detectors' segments: frames 0 and 1 carry the default chain's results,
// frame 2 the results of a chain without segmentation, frame 3 none (the detectors skipped it).
class EstimateBoxFromSegments : public EstimateBoxTest {
 protected:
  void SetUp() override {
    EstimateBoxTest::SetUp();
    DetectorConfig config;
    config.bowls = false;
    const DetectorChain chain = makeDetectorChain(config);
    for (int i = 0; i < 2; ++i) {
      const auto frame = srv.cache().bySequence(i)->frame;
      ASSERT_TRUE(srv.cache().publishResults(
          i, std::make_shared<const FrameResults>(chain.process(*frame))));
    }
    config.segmentation.reset();
    const auto frame2 = srv.cache().bySequence(2)->frame;
    ASSERT_TRUE(srv.cache().publishResults(
        2, std::make_shared<const FrameResults>(makeDetectorChain(config).process(*frame2))));
    Frame skipped = *frame2;
    skipped.timestamp_ns = kServerT0 + 3 * kFramePeriodNs;
    skipped.sequence = 3;
    ASSERT_TRUE(srv.cache().insert(std::make_shared<const Frame>(std::move(skipped))));
  }
};

TEST_F(EstimateBoxFromSegments, Mode4HoldsTheObjectsPointsInAnUprightBox) {
  const auto& object = someObject(1);
  const cv::Rect r = object.image_box;
  v1::EstimateBoxResponse response;
  const auto status =
      call(kServerT0 + kFramePeriodNs, r.tl(), r.br() - cv::Point(1, 1), 4, response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.corners_size(), 8);
  EXPECT_EQ(response.mode(), v1::BOX_MODE_SEGMENTS);
  EXPECT_EQ(response.frame_sequence(), 1u);
  EXPECT_GT(response.stats().used_pixels(), 0u);
  // The requirement for mode 4, on one object: 0.95 of its visible points.
  EXPECT_GE(shareInside(response, 1, object, 0.0), 0.95) << object.name;
}

TEST_F(EstimateBoxFromSegments, FramesWithoutSegmentsAreFailedPreconditionSayingWhy) {
  const cv::Rect r = someObject(2).image_box;
  v1::EstimateBoxResponse response;
  auto status = call(kServerT0 + 2 * kFramePeriodNs, r.tl(), r.br() - cv::Point(1, 1), 4, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("segmentation or plane stage off"), std::string::npos)
      << status.error_message();
  status = call(kServerT0 + 3 * kFramePeriodNs, r.tl(), r.br() - cv::Point(1, 1), 4, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  // Modes 1-3 need no detector results: the skipped frame still answers.
  EXPECT_TRUE(
      call(kServerT0 + 3 * kFramePeriodNs, r.tl(), r.br() - cv::Point(1, 1), 2, response).ok());
}

TEST_F(EstimateBoxFromSegments, AnRoiOnNoObjectIsFailedPrecondition) {
  v1::EstimateBoxResponse response;
  const auto status = call(kServerT0, {319, 239}, {321, 241}, 4, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("no segment lies mostly inside the ROI"), std::string::npos)
      << status.error_message();
}

TEST(EstimateBoxEmptyCache, IsUnavailable) {
  TestServer srv;
  v1::EstimateBoxRequest request;
  request.mutable_p1()->set_x(1);
  request.mutable_p2()->set_x(2);
  v1::EstimateBoxResponse response;
  const auto status = srv.stub().EstimateBox(clientContext().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
}

}  // namespace
}  // namespace shapesense::testing
