#pragma once
// The whole daemon in one object: source -> pipeline -> cache -> gRPC server. main() parses
// options into DaemonOptions and runs one; integration tests run one in-process.

#include <cstddef>
#include <memory>
#include <string>

#include "shapesense/core/pipeline/detector_chain.h"
#include "shapesense/driver/frame_source.h"
#include "shapesense/server/frame_cache.h"
#include "shapesense/server/frame_tap.h"
#include "shapesense/server/object_model_store.h"
#include "shapesense/server/pipeline.h"
#include "shapesense/server/pipeline_health.h"
#include "shapesense/server/recording_root.h"
#include "shapesense/server/rpc_server.h"
#include "shapesense/server/summary_hub.h"
#include "shapesense/server/transport_security.h"

namespace shapesense {

inline constexpr const char* kDefaultListenAddress = "127.0.0.1:50551";

struct DaemonOptions {
  /// A source spec as openSource takes it (driver/open_source.h: kSourceSpecs).
  std::string source = "synthetic";
  /// Recorded sources: at the recorded rate, or as fast as the pipeline takes frames.
  Pacing pacing = Pacing::kRecorded;
  /// Replay: start again at the end of the recording.
  bool loop = false;
  /// Frames the cache holds; 90 = 3 s at 30 fps.
  std::size_t cache_frames = FrameCache::kDefaultCapacity;
  /// gRPC listen address; port 0 picks a free one.
  std::string listen = kDefaultListenAddress;
  /// TLS, tokens, reflection; checked against `listen` (checkTransportOptions).
  TransportSecurity security;
  /// Where Record writes (created at start when missing); an empty root disables Record.
  RecordLimits record;
  /// The taught objects' folder (created at start when missing; TeachObject writes only
  /// there) and the most models it may hold. Empty: the daemon keeps no taught objects.
  std::filesystem::path object_models;
  std::size_t object_models_max = ObjectModelStore::kDefaultMaxModels;
  /// Runs the taught-object stage on every frame (TaughtObjectStage: the folder's objects
  /// followed from frame to frame); needs `object_models`. Off by default: a search costs
  /// tens of milliseconds of the detector thread's frame.
  bool find_taught_objects = false;
  /// How long the source may deliver nothing, or the detectors take on one frame, before
  /// health() says the pipeline hangs.
  std::chrono::steady_clock::duration stall_limit = std::chrono::seconds(10);
  DetectorConfig detectors;
  /// The capture and detector threads' priority (pipeline.h). At -10 they come before every
  /// process of default priority on the machine, clients included, where the system allows it.
  PipelineOptions pipeline{.thread_nice = -10};
  /// Query workers, call and stream limits, message size, keepalive (rpc_server.h).
  ServerLimits limits;
};

class Daemon {
 public:
  /// Opens the source, starts the pipeline and the gRPC server. Throws on bad options:
  /// std::invalid_argument for options that contradict each other or the listen policy.
  explicit Daemon(const DaemonOptions& options);
  ~Daemon();

  int port() const { return server_->port(); }
  /// Whether the pipeline is alive now (pipeline_health.h): the watchdog's question.
  HealthVerdict health() const;
  /// Stops serving (open streams end), then stops the pipeline.
  void shutdown();

  const FrameCache& cache() const { return cache_; }
  Pipeline& pipeline() { return *pipeline_; }

 private:
  FrameCache cache_;
  SummaryHub hub_;
  FrameTap tap_;
  // Outlives the server and the pipeline (its taught-object stage asks it for the models).
  std::unique_ptr<ObjectModelStore> object_models_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<RpcServer> server_;
  std::chrono::steady_clock::duration stall_limit_;
};

}  // namespace shapesense
