// GetScene through a real in-process gRPC server over frames of the synthetic table-top scene
// processed by the standard detector chain: the scene holds the chain's accumulated planes and
// tracked things, a preview of the same frame, fits the thin-link budget, and refuses what it
// should.

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gtest/gtest.h>

#include "server_fixture.h"
#include "shapesense/core/pipeline/detector_chain.h"
#include "synthetic_frames.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using testing::clientContext;
using testing::TestServer;

constexpr int kFrames = 10;

class GetSceneTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sequence_ =
        new std::vector<synthetic::RenderedFrame>(testing::renderSyntheticSequence(1, kFrames));
    results_ = new std::vector<std::shared_ptr<const FrameResults>>();
    const DetectorChain chain = makeDetectorChain(DetectorConfig{});
    for (const auto& rendered : *sequence_) {
      results_->push_back(std::make_shared<const FrameResults>(chain.process(rendered.frame)));
    }
  }
  static void TearDownTestSuite() {
    delete sequence_;
    delete results_;
  }

  /// Caches every frame of the sequence, with results for the first `processed` of them.
  void cacheSequence(int processed = kFrames) {
    for (int i = 0; i < kFrames; ++i) {
      auto frame = std::make_shared<const Frame>((*sequence_)[i].frame);
      ASSERT_TRUE(srv.cache().insert(frame));
      if (i < processed) {
        ASSERT_TRUE(srv.cache().publishResults(frame->sequence, (*results_)[i]));
      }
    }
  }

  grpc::Status getScene(v1::GetSceneRequest request, v1::SceneUpdate& scene) {
    auto context = clientContext(10s);
    return srv.stub().GetScene(context.get(), request, &scene);
  }

  static const Frame& frame(int i) { return (*sequence_)[i].frame; }
  static const FrameResults& results(int i) { return *(*results_)[i]; }

  TestServer srv{32};
  static std::vector<synthetic::RenderedFrame>* sequence_;
  static std::vector<std::shared_ptr<const FrameResults>>* results_;
};

std::vector<synthetic::RenderedFrame>* GetSceneTest::sequence_ = nullptr;
std::vector<std::shared_ptr<const FrameResults>>* GetSceneTest::results_ = nullptr;

TEST_F(GetSceneTest, HoldsTheAccumulatedPlanesAndTrackedThingsOfTheFrame) {
  cacheSequence();
  v1::SceneUpdate scene;
  ASSERT_TRUE(getScene({}, scene).ok());
  const int last = kFrames - 1;
  EXPECT_EQ(scene.info().timestamp_ns(), frame(last).timestamp_ns);
  EXPECT_TRUE(scene.full());
  EXPECT_EQ(scene.intrinsics().fx(), frame(last).intrinsics.fx);
  const auto& planes = results(last).planes->accumulated;
  ASSERT_GE(planes.size(), 2u) << "the table-top scene has at least a floor and a table";
  ASSERT_EQ(scene.planes_size(), static_cast<int>(planes.size()));
  for (int i = 0; i < scene.planes_size(); ++i) {
    const auto& sent = scene.planes(i);
    EXPECT_EQ(sent.id(), planes[i].id);
    EXPECT_NEAR(sent.d(), planes[i].d, 1e-12);
    ASSERT_EQ(sent.polygon_xyz_size(), 3 * static_cast<int>(planes[i].polygon.size()));
    EXPECT_EQ(sent.triangles_size(), 3 * static_cast<int>(planes[i].triangles.size()));
    // Every vertex lies on the plane to float precision.
    const Eigen::Vector3d n(sent.normal().x(), sent.normal().y(), sent.normal().z());
    for (int v = 0; v + 2 < sent.polygon_xyz_size(); v += 3) {
      const Eigen::Vector3d p(sent.polygon_xyz(v), sent.polygon_xyz(v + 1),
                              sent.polygon_xyz(v + 2));
      EXPECT_NEAR(n.dot(p) + sent.d(), 0.0, 1e-5);
    }
  }
  ASSERT_TRUE(results(last).things.has_value());
  const auto& things = *results(last).things;
  ASSERT_EQ(scene.objects_size(), static_cast<int>(things.size()));
  for (int i = 0; i < scene.objects_size(); ++i) {
    const auto& object = scene.objects(i);
    EXPECT_EQ(object.id(), things[i].id);
    ASSERT_EQ(object.corners_size(), 8);
    EXPECT_NEAR(object.width_m(), (things[i].corners[1] - things[i].corners[0]).norm(), 1e-12);
    EXPECT_GT(object.frames_seen(), 2u);
  }
  EXPECT_GT(scene.timings_size(), 0);
}

TEST_F(GetSceneTest, AFullTableTopSceneFitsOnePercentOfTheRawFrame) {
  // Requirement (issue 19): a full scene update <= 1% of the raw 640x480 depth + colour frame
  // it describes (1.5 MB: 15 KB); a 320x240 colour preview <= 20 KB.
  cacheSequence();
  v1::SceneUpdate scene;
  ASSERT_TRUE(getScene({}, scene).ok());
  const std::size_t raw_bytes = 640 * 480 * (2 + 3);
  EXPECT_LE(scene.ByteSizeLong(), raw_bytes / 100);
  v1::GetSceneRequest request;
  request.mutable_preview()->set_kind(v1::PreviewRequest::COLOUR);
  request.mutable_preview()->set_width(320);
  v1::SceneUpdate with_preview;
  ASSERT_TRUE(getScene(request, with_preview).ok());
  EXPECT_GT(with_preview.preview_jpeg().size(), 1000u);
  EXPECT_LE(with_preview.preview_jpeg().size(), 20'000u);
}

TEST_F(GetSceneTest, ThePreviewShowsTheSameFrame) {
  cacheSequence();
  const int shown = 4;
  v1::GetSceneRequest request;
  request.set_at_ns(frame(shown).timestamp_ns);
  request.mutable_preview()->set_kind(v1::PreviewRequest::COLOUR);
  request.mutable_preview()->set_width(160);
  request.mutable_preview()->set_quality(90);
  v1::SceneUpdate scene;
  ASSERT_TRUE(getScene(request, scene).ok());
  EXPECT_EQ(scene.info().sequence(), frame(shown).sequence);
  ASSERT_EQ(scene.preview_width(), 160u);
  ASSERT_EQ(scene.preview_height(), 120u);
  const std::vector<unsigned char> bytes(scene.preview_jpeg().begin(), scene.preview_jpeg().end());
  const cv::Mat preview = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(preview.size(), cv::Size(160, 120));
  cv::Mat expected;
  cv::resize(frame(shown).rgb, expected, preview.size(), 0, 0, cv::INTER_AREA);
  // JPEG at quality 90: a mean error of a few grey levels; another frame of the moving
  // synthetic camera differs by far more at its edges, so compare the mean only as a sanity
  // bound.
  EXPECT_LT(cv::norm(preview, expected, cv::NORM_L1) / (160.0 * 120 * 3), 6.0);
}

TEST_F(GetSceneTest, ADepthPreviewIsBlackWhereThereIsNoReading) {
  cacheSequence();
  v1::GetSceneRequest request;
  request.mutable_preview()->set_kind(v1::PreviewRequest::DEPTH);
  request.mutable_preview()->set_width(640);
  request.mutable_preview()->set_quality(100);
  v1::SceneUpdate scene;
  ASSERT_TRUE(getScene(request, scene).ok());
  const std::vector<unsigned char> bytes(scene.preview_jpeg().begin(), scene.preview_jpeg().end());
  const cv::Mat preview = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(preview.size(), frame(kFrames - 1).depth.size());
  cv::Mat grey;
  cv::cvtColor(preview, grey, cv::COLOR_BGR2GRAY);
  const cv::Mat holes = frame(kFrames - 1).depth == 0;
  cv::Mat eroded;  // JPEG blurs the hole borders
  cv::erode(holes, eroded, cv::Mat::ones(5, 5, CV_8U));
  ASSERT_GT(cv::countNonZero(eroded), 50) << "the synthetic frame has shadows without depth";
  EXPECT_LT(cv::mean(grey, eroded)[0], 12.0);
  EXPECT_GT(cv::mean(grey, ~holes)[0], 40.0);
}

TEST_F(GetSceneTest, TimeZeroIsTheNewestProcessedFrame) {
  cacheSequence(/*processed=*/kFrames - 2);
  v1::SceneUpdate scene;
  ASSERT_TRUE(getScene({}, scene).ok());
  EXPECT_EQ(scene.info().sequence(), frame(kFrames - 3).sequence);
  v1::GetSceneRequest request;
  request.set_at_ns(frame(kFrames - 1).timestamp_ns);
  const auto status = getScene(request, scene);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
}

TEST_F(GetSceneTest, RefusesWhatItShould) {
  v1::SceneUpdate scene;
  EXPECT_EQ(getScene({}, scene).error_code(), grpc::StatusCode::UNAVAILABLE);
  cacheSequence();
  v1::GetSceneRequest before;
  before.set_at_ns(frame(0).timestamp_ns - 1);
  EXPECT_EQ(getScene(before, scene).error_code(), grpc::StatusCode::OUT_OF_RANGE);
  for (const int width : {5, 1281, 1 << 30}) {
    v1::GetSceneRequest request;
    request.mutable_preview()->set_kind(v1::PreviewRequest::COLOUR);
    request.mutable_preview()->set_width(static_cast<std::uint32_t>(width));
    const auto status = getScene(request, scene);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << width;
    EXPECT_NE(status.error_message().find("preview.width"), std::string::npos);
  }
  v1::GetSceneRequest quality;
  quality.mutable_preview()->set_quality(101);
  EXPECT_EQ(getScene(quality, scene).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v1::GetSceneRequest kind;
  kind.mutable_preview()->set_kind(static_cast<v1::PreviewRequest::Kind>(9));
  EXPECT_EQ(getScene(kind, scene).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(GetSceneTest, TheSessionIdIsGetStatusOne) {
  cacheSequence();
  v1::SceneUpdate scene;
  ASSERT_TRUE(getScene({}, scene).ok());
  auto context = clientContext();
  v1::GetStatusResponse status;
  ASSERT_TRUE(srv.stub().GetStatus(context.get(), {}, &status).ok());
  EXPECT_EQ(scene.session_id().size(), 32u);
  EXPECT_EQ(scene.session_id(), status.session_id());
  TestServer other;
  auto other_context = clientContext();
  v1::GetStatusResponse other_status;
  ASSERT_TRUE(other.stub().GetStatus(other_context.get(), {}, &other_status).ok());
  EXPECT_NE(other_status.session_id(), status.session_id());
}

}  // namespace
}  // namespace shapesense
