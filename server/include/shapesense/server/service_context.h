#pragma once
// What the gRPC handlers read: the cache, the Watch hub and the pipeline's status. Handlers get
// it by reference and never own any of it, so they can be tested with a cache filled by hand.

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include <grpcpp/support/status.h>

#include "shapesense/server/call_latencies.h"
#include "shapesense/server/frame_cache.h"
#include "shapesense/server/frame_tap.h"
#include "shapesense/server/object_model_store.h"
#include "shapesense/server/pipeline.h"
#include "shapesense/server/png_cache.h"
#include "shapesense/server/recording_root.h"
#include "shapesense/server/scene_surface_cache.h"
#include "shapesense/server/stream_quota.h"
#include "shapesense/server/summary_hub.h"

namespace shapesense {

/// A random id for one daemon start (GetStatus and SceneUpdate.session_id): a client that sees
/// it change knows the daemon restarted.
std::string newSessionId();

struct ServiceContext {
  const FrameCache& cache;
  SummaryHub& hub;
  /// The pipeline's counters; a default-constructed status when no pipeline runs (tests).
  std::function<PipelineStatus()> pipeline_status = [] { return PipelineStatus{}; };
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  /// Set at shutdown so open streams end promptly.
  const std::atomic<bool>* shutting_down = nullptr;
  /// Watch streams per client and in all; null: no limit (the RpcServer sets its own).
  StreamQuota* watch_streams = nullptr;
  /// Every frame the source delivers (Record); null when nothing feeds one (Record then
  /// answers UNIMPLEMENTED).
  FrameTap* frame_tap = nullptr;
  /// Where and how much Record may write.
  RecordLimits record = {};
  /// Set while a Record call runs; shared by the copies of this context.
  std::shared_ptr<std::atomic<bool>> recording = std::make_shared<std::atomic<bool>>(false);
  /// The taught objects (TeachObject, ListObjectModels, FindObjects); null when the daemon has
  /// none (those calls then answer FAILED_PRECONDITION).
  ObjectModelStore* object_models = nullptr;
  /// The last searched frame's surface; shared by the copies of this context.
  std::shared_ptr<SceneSurfaceCache> scene_surfaces = std::make_shared<SceneSurfaceCache>();
  /// PNGs of the frames' images and labels; shared by the copies of this context.
  std::shared_ptr<PngCache> pngs = std::make_shared<PngCache>();
  /// How long unary calls took, by method (the RpcServer's call log fills it); for GetStatus.
  std::shared_ptr<CallLatencies> call_latencies = std::make_shared<CallLatencies>();

  std::string session_id = newSessionId();
  bool shuttingDown() const { return shutting_down && shutting_down->load(); }
};

/// The cached frame at T (0 = newest), or the gRPC status the API promises: INVALID_ARGUMENT
/// for a negative T, UNAVAILABLE while nothing is cached, OUT_OF_RANGE (naming the cached range)
/// for T before the cache.
grpc::Status lookupFrame(const FrameCache& cache, std::int64_t at_ns, CachedFrame& out);

/// The store, or FAILED_PRECONDITION saying the daemon has no object models folder.
grpc::Status objectModelsOf(const ServiceContext& context, ObjectModelStore*& out);

/// lookupFrame for queries of detector results: also FAILED_PRECONDITION when the detectors
/// have not processed the frame (skipped, or still running). On OK, out.results is set.
grpc::Status lookupProcessedFrame(const FrameCache& cache, std::int64_t at_ns, CachedFrame& out);

}  // namespace shapesense
