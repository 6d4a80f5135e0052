// WatchScene through a real in-process gRPC server, with scenes made by hand so each update's
// content is known: the first update is full, later ones carry only changes and removals, the
// rate limit holds, a slow reader gets the newest scene with the count it missed, a full update
// comes back on schedule, and bad options are refused.

#include <chrono>
#include <thread>

#include <grpcpp/create_channel.h>
#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

#include "server_fixture.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using testing::clientContext;
using testing::kFramePeriodNs;
using testing::kServerT0;
using testing::ServerTest;
using testing::waitFor;

DetectedPlane squarePlane(std::uint16_t id, double d) {
  DetectedPlane plane;
  plane.id = id;
  plane.normal = Eigen::Vector3d(0, -1, 0);
  plane.d = d;
  plane.box = cv::Rect(0, 10, 32, 14);
  for (const auto& [x, z] : {std::pair{-0.5, 1.0}, {0.5, 1.0}, {0.5, 2.0}, {-0.5, 2.0}}) {
    plane.polygon.emplace_back(x, d, z);
  }
  plane.triangles = {{0, 1, 2}, {0, 2, 3}};
  return plane;
}

TrackedThing thingAt(std::uint32_t id, ThingKind kind, const Eigen::Vector3d& centre) {
  TrackedThing thing;
  thing.id = id;
  thing.kind = kind;
  for (int i = 0; i < 8; ++i) {
    thing.corners[i] =
        centre + 0.05 * Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  }
  thing.image_box = cv::Rect(10, 5, 6, 6);
  thing.frames_seen = 5;
  return thing;
}

struct SceneSpec {
  std::vector<DetectedPlane> planes;
  std::vector<TrackedThing> things;
};

class WatchSceneTest : public ServerTest {
 protected:
  std::unique_ptr<grpc::ClientReader<v1::SceneUpdate>> watch(grpc::ClientContext* context,
                                                             v1::WatchSceneRequest request = {}) {
    return srv.stub().WatchScene(context, request);
  }

  /// Caches the next frame with the given scene as its results and publishes it.
  void publish(const SceneSpec& spec) {
    const TimestampNs t = kServerT0 + static_cast<TimestampNs>(srv.added().size()) * kFramePeriodNs;
    auto frame = srv.add(t, true, /*publish_results=*/false);
    auto results = std::make_shared<FrameResults>();
    results->planes = PlaneResult{"hough", {}, spec.planes};
    results->things = spec.things;
    ASSERT_TRUE(srv.cache().publishResults(frame->sequence, results));
    srv.hub().publish(*srv.cache().bySequence(frame->sequence));
  }

  bool subscribed() {
    return waitFor([&] { return srv.hub().subscribers() == 1; });
  }
};

const Eigen::Vector3d kLeft(-0.2, 0.1, 1.2);
const Eigen::Vector3d kRight(0.3, 0.1, 1.4);

TEST_F(WatchSceneTest, SendsTheWholeSceneFirstAndThenOnlyWhatChanged) {
  auto context = clientContext(10s);
  auto reader = watch(context.get());
  ASSERT_TRUE(subscribed());
  const SceneSpec first{
      {squarePlane(1, 0.8), squarePlane(2, 1.5)},
      {thingAt(1, ThingKind::kObject, kLeft), thingAt(2, ThingKind::kBowl, kRight)}};
  publish(first);
  v1::SceneUpdate update;
  ASSERT_TRUE(reader->Read(&update));
  EXPECT_TRUE(update.full());
  EXPECT_EQ(update.planes_size(), 2);
  EXPECT_EQ(update.objects_size(), 2);
  EXPECT_EQ(update.objects(1).kind(), v1::SceneObject::BOWL);
  EXPECT_EQ(update.session_id().size(), 32u);

  // Nothing moved beyond the tolerances: an empty change set for the same session.
  SceneSpec same = first;
  same.things[0].corners[0].x() += 0.001;
  same.planes[0].d += 0.001;
  publish(same);
  ASSERT_TRUE(reader->Read(&update));
  EXPECT_FALSE(update.full());
  EXPECT_EQ(update.planes_size(), 0);
  EXPECT_EQ(update.objects_size(), 0);
  EXPECT_EQ(update.removed_object_ids_size(), 0);

  // The bowl moves 3 cm, the object leaves, a plane moves 2 cm, a new plane comes.
  SceneSpec changed{{squarePlane(1, 0.82), squarePlane(2, 1.5), squarePlane(3, 2.5)},
                    {thingAt(2, ThingKind::kBowl, kRight + Eigen::Vector3d(0.03, 0, 0))}};
  publish(changed);
  ASSERT_TRUE(reader->Read(&update));
  EXPECT_FALSE(update.full());
  ASSERT_EQ(update.planes_size(), 2);
  EXPECT_EQ(update.planes(0).id(), 1u);
  EXPECT_EQ(update.planes(1).id(), 3u);
  ASSERT_EQ(update.objects_size(), 1);
  EXPECT_EQ(update.objects(0).id(), 2u);
  ASSERT_EQ(update.removed_object_ids_size(), 1);
  EXPECT_EQ(update.removed_object_ids(0), 1u);
  EXPECT_EQ(update.removed_plane_ids_size(), 0);

  // Small steps that each stay under the tolerance still add up: deltas are measured against
  // what the client was sent, so the client's box never drifts far from the truth.
  SceneSpec drifting = changed;
  int sent_moves = 0;
  for (int step = 1; step <= 4; ++step) {
    for (auto& corner : drifting.things[0].corners) corner.x() += 0.003;
    publish(drifting);
    ASSERT_TRUE(reader->Read(&update));
    sent_moves += update.objects_size();
  }
  EXPECT_EQ(sent_moves, 2) << "12 mm in 3 mm steps: sent after 6 mm and after 12 mm";
  context->TryCancel();
  while (reader->Read(&update)) {
  }
  EXPECT_TRUE(waitFor([&] { return srv.hub().subscribers() == 0; }));
}

TEST_F(WatchSceneTest, KeepsToTheRateAndCountsWhatItDropped) {
  v1::WatchSceneRequest request;
  request.set_max_rate_hz(5);
  auto context = clientContext(10s);
  auto reader = watch(context.get(), request);
  ASSERT_TRUE(subscribed());
  std::thread publisher([&] {
    for (int i = 0; i < 30; ++i) {  // one second at 30 fps
      publish({{squarePlane(1, 0.8 + 0.01 * i)}, {}});
      std::this_thread::sleep_for(33ms);
    }
  });
  std::vector<v1::SceneUpdate> updates;
  std::vector<std::chrono::steady_clock::time_point> arrivals;
  v1::SceneUpdate update;
  while (reader->Read(&update)) {
    updates.push_back(update);
    arrivals.push_back(std::chrono::steady_clock::now());
    if (update.info().sequence() == 29) break;
  }
  publisher.join();
  ASSERT_GE(updates.size(), 4u);
  EXPECT_LE(updates.size(), 8u) << "5 updates a second over about 1.2 s";
  std::uint64_t accounted = 0;
  for (const auto& u : updates) accounted += 1 + u.dropped_before();
  EXPECT_EQ(accounted, 30u) << "every frame was either sent or counted as dropped";
  for (std::size_t i = 1; i < arrivals.size(); ++i) {
    EXPECT_GE(arrivals[i] - arrivals[i - 1], 150ms) << i;
  }
  EXPECT_EQ(updates.back().info().sequence(), 29u) << "the newest frame is sent last";
  context->TryCancel();
  while (reader->Read(&update)) {
  }
}

TEST_F(WatchSceneTest, ASlowReaderGetsTheNewestSceneNotAReplay) {
  // A client that asks the transport to hold as little as it can for it (as the console does).
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 1);
  auto channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(srv.port()),
                                           grpc::InsecureChannelCredentials(), args);
  auto stub = v1::ShapeSense::NewStub(channel);
  auto context = clientContext(10s);
  auto reader = stub->WatchScene(context.get(), v1::WatchSceneRequest());
  ASSERT_TRUE(subscribed());
  for (int i = 0; i < 40; ++i) publish({{squarePlane(1, 0.5 + 0.02 * i)}, {}});
  std::this_thread::sleep_for(200ms);
  v1::SceneUpdate update;
  std::uint64_t read = 0, dropped = 0;
  std::uint64_t last_sequence = 0;
  while (last_sequence != 39 && reader->Read(&update)) {
    ++read;
    dropped += update.dropped_before();
    last_sequence = update.info().sequence();
  }
  EXPECT_EQ(last_sequence, 39u);
  EXPECT_EQ(read + dropped, 40u);
  EXPECT_LE(read, 3u) << "one being written, one waiting, and what flow control let through";
  EXPECT_EQ(update.planes_size(), 1) << "the plane moved since the update this reader got";
  context->TryCancel();
  while (reader->Read(&update)) {
  }
}

TEST_F(WatchSceneTest, AFullUpdateComesBackOnSchedule) {
  v1::WatchSceneRequest request;
  request.set_full_every_s(0.2);
  auto context = clientContext(10s);
  auto reader = watch(context.get(), request);
  ASSERT_TRUE(subscribed());
  int full = 0;
  v1::SceneUpdate update;
  for (int i = 0; i < 15; ++i) {  // half a second
    publish({{squarePlane(1, 0.8)}, {}});
    ASSERT_TRUE(reader->Read(&update));
    if (update.full()) {
      ++full;
      EXPECT_EQ(update.planes_size(), 1) << "a full update repeats unchanged things";
    }
    std::this_thread::sleep_for(33ms);
  }
  EXPECT_GE(full, 2);
  EXPECT_LE(full, 4);
  context->TryCancel();
  while (reader->Read(&update)) {
  }
}

TEST_F(WatchSceneTest, CarriesAPreviewAtItsOwnRate) {
  v1::WatchSceneRequest request;
  request.mutable_preview()->set_kind(v1::PreviewRequest::DEPTH);
  request.mutable_preview()->set_width(16);
  request.mutable_preview()->set_rate_hz(2);
  auto context = clientContext(10s);
  auto reader = watch(context.get(), request);
  ASSERT_TRUE(subscribed());
  int with_preview = 0;
  v1::SceneUpdate update;
  for (int i = 0; i < 12; ++i) {  // 0.4 s
    publish({{squarePlane(1, 0.8)}, {}});
    ASSERT_TRUE(reader->Read(&update));
    if (!update.preview_jpeg().empty()) {
      ++with_preview;
      const std::vector<unsigned char> bytes(update.preview_jpeg().begin(),
                                             update.preview_jpeg().end());
      const cv::Mat image = cv::imdecode(bytes, cv::IMREAD_COLOR);
      EXPECT_EQ(image.cols, 16);
      EXPECT_EQ(image.rows, 12);  // the 32 x 24 test frame's aspect
    }
    std::this_thread::sleep_for(33ms);
  }
  EXPECT_GE(with_preview, 1);
  EXPECT_LE(with_preview, 2);
  context->TryCancel();
  while (reader->Read(&update)) {
  }
}

TEST_F(WatchSceneTest, AStreamWaitingForItsRateEndsAtOnceAtShutdown) {
  v1::WatchSceneRequest request;
  request.set_max_rate_hz(0.1);  // ten seconds between updates
  auto context = clientContext(20s);
  auto reader = watch(context.get(), request);
  ASSERT_TRUE(subscribed());
  publish({{squarePlane(1, 0.8)}, {}});
  v1::SceneUpdate update;
  ASSERT_TRUE(reader->Read(&update));
  publish({{squarePlane(1, 0.9)}, {}});  // now it waits for its rate
  std::this_thread::sleep_for(50ms);
  const auto start = std::chrono::steady_clock::now();
  srv.hub().closeAll();
  EXPECT_FALSE(reader->Read(&update));
  EXPECT_TRUE(reader->Finish().ok());
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);
}

TEST_F(WatchSceneTest, RefusesOptionsOutsideTheirLimits) {
  const auto refused = [&](v1::WatchSceneRequest request) {
    auto context = clientContext();
    auto reader = watch(context.get(), request);
    v1::SceneUpdate update;
    EXPECT_FALSE(reader->Read(&update));
    return reader->Finish();
  };
  v1::WatchSceneRequest fast;
  fast.set_max_rate_hz(100);
  EXPECT_EQ(refused(fast).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v1::WatchSceneRequest negative;
  negative.set_max_rate_hz(-1);
  EXPECT_EQ(refused(negative).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v1::WatchSceneRequest full;
  full.set_full_every_s(std::nan(""));
  EXPECT_EQ(refused(full).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v1::WatchSceneRequest preview;
  preview.mutable_preview()->set_width(4000);
  const auto status = refused(preview);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("preview.width"), std::string::npos);
  EXPECT_EQ(srv.hub().subscribers(), 0u);
}

}  // namespace
}  // namespace shapesense
