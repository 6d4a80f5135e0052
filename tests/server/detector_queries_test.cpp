// GetSegments, GetPlanes and GetDetectedBoxes through a real in-process gRPC server, over a
// cache whose frames carry results of the real detector chain on synthetic frames.

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "server_fixture.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::testing {
namespace {

class DetectorQueries : public ::testing::Test {
 protected:
  void SetUp() override {
    synthetic::SceneParams params;
    params.seed = 2;
    const synthetic::SyntheticScene scene(params);
    DetectorConfig config;
    config.segmentation = SegmentationMethod::kFused;
    const DetectorChain chain = makeDetectorChain(config);
    for (int i = 0; i < 2; ++i) {
      auto rendered = scene.render(i, kServerT0 + i * kFramePeriodNs);
      rendered.frame.sequence = i;
      auto frame = std::make_shared<const Frame>(std::move(rendered.frame));
      ASSERT_TRUE(srv.cache().insert(frame));
      results.push_back(std::make_shared<const FrameResults>(chain.process(*frame)));
      ASSERT_TRUE(srv.cache().publishResults(i, results.back()));
    }
    // A third frame the detectors skipped.
    auto skipped = scene.render(2, kServerT0 + 2 * kFramePeriodNs);
    skipped.frame.sequence = 2;
    ASSERT_TRUE(srv.cache().insert(std::make_shared<const Frame>(std::move(skipped.frame))));
  }

  static cv::Mat decode(const std::string& png) {
    return cv::imdecode(std::vector<unsigned char>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
  }

  TestServer srv;
  std::vector<std::shared_ptr<const FrameResults>> results;
};

TEST_F(DetectorQueries, SegmentsComeFromThePipelineOrAreComputedOnRequest) {
  v1::GetSegmentsRequest request;
  request.set_at_ns(kServerT0 + kFramePeriodNs);
  v1::GetSegmentsResponse response;
  ASSERT_TRUE(srv.stub().GetSegments(clientContext().get(), request, &response).ok());
  EXPECT_FALSE(response.computed_on_request());
  EXPECT_EQ(response.method(), "fused");
  EXPECT_EQ(response.frame_timestamp_ns(), kServerT0 + kFramePeriodNs);
  ASSERT_EQ(response.segments_size(), static_cast<int>(results[1]->segmentation->segments.size()));
  const cv::Mat labels = decode(response.labels_png());
  ASSERT_EQ(labels.type(), CV_16UC1);
  EXPECT_EQ(cv::countNonZero(labels != results[1]->segmentation->labels), 0);

  request.set_method("depth_step");
  ASSERT_TRUE(srv.stub().GetSegments(clientContext().get(), request, &response).ok());
  EXPECT_TRUE(response.computed_on_request());
  EXPECT_EQ(response.method(), "depth_step");
  EXPECT_GT(response.segments_size(), 0);

  request.set_method("watershed-ish");
  const auto status = srv.stub().GetSegments(clientContext().get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("plane_prediction"), std::string::npos);
}

TEST_F(DetectorQueries, PlanesOfTheFrameAndAccumulated) {
  v1::GetPlanesRequest request;
  request.set_at_ns(kServerT0 + kFramePeriodNs);
  v1::GetPlanesResponse response;
  ASSERT_TRUE(srv.stub().GetPlanes(clientContext().get(), request, &response).ok());
  EXPECT_EQ(response.detector(), "hough");
  const auto& planes = results[1]->planes->frame.planes;
  ASSERT_EQ(response.planes_size(), static_cast<int>(planes.size()));
  for (int i = 0; i < response.planes_size(); ++i) {
    const auto& p = response.planes(i);
    EXPECT_EQ(p.id(), planes[i].id);
    EXPECT_NEAR(std::hypot(p.normal().x(), p.normal().y(), p.normal().z()), 1.0, 1e-9);
    EXPECT_GT(p.d(), 0.0);
    EXPECT_EQ(p.triangles_size() % 3, 0);
  }
  const cv::Mat labels = decode(response.labels_png());
  EXPECT_EQ(cv::countNonZero(labels != results[1]->planes->frame.labels), 0);

  request.set_view(v1::GetPlanesRequest::ACCUMULATED);
  ASSERT_TRUE(srv.stub().GetPlanes(clientContext().get(), request, &response).ok());
  EXPECT_TRUE(response.labels_png().empty());
  EXPECT_EQ(response.planes_size(), static_cast<int>(results[1]->planes->accumulated.size()));
}

TEST_F(DetectorQueries, SkippedFrameIsFailedPrecondition) {
  v1::GetPlanesRequest planes;
  planes.set_at_ns(kServerT0 + 2 * kFramePeriodNs);
  v1::GetPlanesResponse planes_response;
  EXPECT_EQ(srv.stub().GetPlanes(clientContext().get(), planes, &planes_response).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  v1::GetDetectedBoxesRequest boxes;
  boxes.set_at_ns(kServerT0 + 2 * kFramePeriodNs);
  v1::GetDetectedBoxesResponse boxes_response;
  EXPECT_EQ(srv.stub().GetDetectedBoxes(clientContext().get(), boxes, &boxes_response).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(DetectorQueries, DetectedBoxesAreTheObjectBoxesOfTheFrame) {
  v1::GetDetectedBoxesRequest request;
  request.set_at_ns(kServerT0);
  v1::GetDetectedBoxesResponse response;
  ASSERT_TRUE(srv.stub().GetDetectedBoxes(clientContext().get(), request, &response).ok());
  // Segment boxes first, then the bowl stage's (on by default; tests/server/get_bowls_test.cpp).
  const auto& expected = results[0]->object_boxes;
  ASSERT_TRUE(results[0]->bowls.has_value());
  int bowl_boxes = 0;
  for (const auto& bowl : *results[0]->bowls) bowl_boxes += bowl.box.has_value();
  ASSERT_EQ(response.boxes_size(), static_cast<int>(expected.size()) + bowl_boxes);
  for (int i = 0; i < static_cast<int>(expected.size()); ++i) {
    const auto& box = response.boxes(i);
    EXPECT_EQ(box.source(), "segment");
    EXPECT_EQ(box.source_id(), expected[i].segment_id);
    EXPECT_EQ(box.p1().x(), expected[i].roi.x);
    EXPECT_EQ(box.p2().y(), expected[i].roi.y + expected[i].roi.height - 1);
    ASSERT_EQ(box.corners_size(), 8);
    EXPECT_DOUBLE_EQ(box.corners(6).z(), expected[i].box.corners[6].z());
  }
  for (int i = static_cast<int>(expected.size()); i < response.boxes_size(); ++i) {
    EXPECT_EQ(response.boxes(i).source(), "bowl");
  }
}

TEST_F(DetectorQueries, BeforeTheCacheIsOutOfRange) {
  v1::GetSegmentsRequest request;
  request.set_at_ns(kServerT0 - 1);
  v1::GetSegmentsResponse response;
  EXPECT_EQ(srv.stub().GetSegments(clientContext().get(), request, &response).error_code(),
            grpc::StatusCode::OUT_OF_RANGE);
}

}  // namespace
}  // namespace shapesense::testing
