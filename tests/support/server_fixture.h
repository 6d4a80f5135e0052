#pragma once
// A real in-process gRPC server over a FrameCache filled by hand, and a client stub to it.

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>
#include <gtest/gtest.h>

#include "shapesense/server/frame_cache.h"
#include "shapesense/server/frame_tap.h"
#include "shapesense/server/object_model_store.h"
#include "shapesense/server/pipeline.h"
#include "shapesense/server/rpc_server.h"
#include "shapesense/server/summary_hub.h"
#include "shapesense/v1/shapesense.grpc.pb.h"

namespace shapesense::testing {

/// 2023-11-14T22:13:20Z: a capture time at epoch scale.
inline constexpr TimestampNs kServerT0 = 1'700'000'000'000'000'000LL;
/// 1/30 s.
inline constexpr TimestampNs kFramePeriodNs = 33'333'333;

/// A frame of `width` x `height` with depth and (optionally) RGB that differ per `seed`.
Frame makeTestFrame(TimestampNs timestamp_ns, std::uint64_t sequence, bool with_rgb = true,
                    int width = 32, int height = 24);

/// Results like the pipeline's: depth statistics of the frame plus a "depth_stats" timing.
std::shared_ptr<const FrameResults> makeTestResults(const Frame& frame);

/// Owns a FrameCache, a SummaryHub and an RpcServer on 127.0.0.1:<free port>, and a client stub.
/// Record writes under recordRoot(): record.root, or a fresh scratch directory when that is
/// empty. Taught objects live in objectModels(), over `object_models_dir` (a fresh scratch
/// directory when empty).
class TestServer {
 public:
  explicit TestServer(std::size_t cache_capacity = 16,
                      std::function<PipelineStatus()> pipeline_status = {},
                      RecordLimits record = {}, ServerLimits limits = {},
                      std::filesystem::path object_models_dir = {},
                      std::size_t max_object_models = ObjectModelStore::kDefaultMaxModels);
  ~TestServer();
  TestServer(const TestServer&) = delete;
  TestServer& operator=(const TestServer&) = delete;

  FrameCache& cache() { return *cache_; }
  SummaryHub& hub() { return hub_; }
  /// Fed by add(), as the pipeline feeds the daemon's (Record listens to it).
  FrameTap& tap() { return tap_; }
  RpcServer& server() { return *server_; }
  v1::ShapeSense::Stub& stub() { return *stub_; }
  std::shared_ptr<grpc::Channel> channel() { return channel_; }
  int port() const { return server_->port(); }
  const std::filesystem::path& recordRoot() const { return record_root_; }
  ObjectModelStore& objectModels() { return *object_models_; }

  /// Inserts the next frame (sequence = frames added so far) captured at `timestamp_ns`, hands
  /// it to tap(), and publishes results for it unless `publish_results` is false.
  std::shared_ptr<const Frame> add(TimestampNs timestamp_ns, bool with_rgb = true,
                                   bool publish_results = true);
  /// Adds `count` frames kFramePeriodNs apart starting at `first_ns`.
  void addMany(int count, TimestampNs first_ns = kServerT0);

  /// Frames added so far, by sequence.
  const std::vector<std::shared_ptr<const Frame>>& added() const { return added_; }

 private:
  std::filesystem::path record_root_;
  std::unique_ptr<FrameCache> cache_;
  std::unique_ptr<ObjectModelStore> object_models_;
  SummaryHub hub_;
  FrameTap tap_;
  std::unique_ptr<RpcServer> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::ShapeSense::Stub> stub_;
  std::vector<std::shared_ptr<const Frame>> added_;
};

/// A ClientContext with a deadline, so a hung server fails the test instead of hanging it.
std::unique_ptr<grpc::ClientContext> clientContext(
    std::chrono::milliseconds deadline = std::chrono::milliseconds(5000));

/// Polls `condition` every millisecond until it holds or `timeout` passes; returns its last value.
bool waitFor(const std::function<bool()>& condition,
             std::chrono::milliseconds timeout = std::chrono::milliseconds(3000));

/// A gtest fixture with one TestServer (capacity 16).
class ServerTest : public ::testing::Test {
 protected:
  TestServer srv;
};

}  // namespace shapesense::testing
