#include "server_fixture.h"

#include <unistd.h>

#include <atomic>
#include <thread>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>

#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/core/pipeline/stages.h"
#include "test_paths.h"

namespace shapesense::testing {

Frame makeTestFrame(TimestampNs timestamp_ns, std::uint64_t sequence, bool with_rgb, int width,
                    int height) {
  Frame frame;
  frame.timestamp_ns = timestamp_ns;
  frame.sequence = sequence;
  frame.intrinsics = CameraIntrinsics{100.0 + static_cast<double>(sequence % 7),
                                      101.5,
                                      width / 2.0 - 0.5,
                                      height / 2.0 - 0.5,
                                      width,
                                      height};
  frame.depth.create(height, width, CV_16UC1);
  cv::RNG rng(0x5eed + sequence);
  // Up to the largest depth a TUM recording holds exactly (65535 units / 5 per mm = 13107 mm).
  rng.fill(frame.depth, cv::RNG::UNIFORM, 300, 13108);
  frame.depth.at<std::uint16_t>(0, 0) = 0;  // no reading
  frame.depth.at<std::uint16_t>(1, 0) = 13107;
  if (with_rgb) {
    frame.rgb.create(height, width, CV_8UC3);
    rng.fill(frame.rgb, cv::RNG::UNIFORM, 0, 256);
  }
  return frame;
}

std::shared_ptr<const FrameResults> makeTestResults(const Frame& frame) {
  auto results = std::make_shared<FrameResults>();
  results->depth_stats = computeDepthStatistics(frame.depth);
  results->timings_ms["depth_stats"] = 0.25 + static_cast<double>(frame.sequence);
  return results;
}

TestServer::TestServer(std::size_t cache_capacity, std::function<PipelineStatus()> pipeline_status,
                       RecordLimits record, ServerLimits limits,
                       std::filesystem::path object_models_dir, std::size_t max_object_models)
    : cache_(std::make_unique<FrameCache>(cache_capacity)) {
  static std::atomic<int> servers{0};
  const std::string server_id = std::to_string(::getpid()) + "-" + std::to_string(servers++);
  if (record.root.empty()) record.root = scratchDir("record-root-" + server_id);
  if (object_models_dir.empty()) object_models_dir = scratchDir("object-models-" + server_id);
  object_models_ = std::make_unique<ObjectModelStore>(object_models_dir, max_object_models);
  record_root_ = record.root;
  ServiceContext context{.cache = *cache_, .hub = hub_};
  if (pipeline_status) context.pipeline_status = std::move(pipeline_status);
  context.frame_tap = &tap_;
  context.record = std::move(record);
  context.object_models = object_models_.get();
  RpcServerOptions options;
  options.limits = std::move(limits);
  server_ = std::make_unique<RpcServer>("127.0.0.1:0", std::move(context), std::move(options));
  channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(server_->port()),
                                 grpc::InsecureChannelCredentials());
  stub_ = v1::ShapeSense::NewStub(channel_);
}

TestServer::~TestServer() {
  stub_.reset();
  channel_.reset();
  hub_.closeAll();
  server_->shutdown();
}

std::shared_ptr<const Frame> TestServer::add(TimestampNs timestamp_ns, bool with_rgb,
                                             bool publish_results) {
  auto frame = std::make_shared<const Frame>(makeTestFrame(timestamp_ns, added_.size(), with_rgb));
  EXPECT_TRUE(cache_->insert(frame)) << "cache rejected frame at " << timestamp_ns;
  tap_.publish(frame);
  if (publish_results) {
    EXPECT_TRUE(cache_->publishResults(frame->sequence, makeTestResults(*frame)));
  }
  added_.push_back(frame);
  return frame;
}

void TestServer::addMany(int count, TimestampNs first_ns) {
  for (int i = 0; i < count; ++i) add(first_ns + i * kFramePeriodNs);
}

std::unique_ptr<grpc::ClientContext> clientContext(std::chrono::milliseconds deadline) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + deadline);
  return context;
}

bool waitFor(const std::function<bool()>& condition, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return condition();
}

}  // namespace shapesense::testing
