#include "shapesense/server/daemon.h"

#include <stdexcept>

#include <spdlog/spdlog.h>

#include "shapesense/driver/open_source.h"
#include "shapesense/server/thread_priority.h"

namespace shapesense {

Daemon::Daemon(const DaemonOptions& options)
    : cache_(options.cache_frames), stall_limit_(options.stall_limit) {
  // Options and files first: a refused listen address, an unreadable token file or bowl
  // models that do not load should fail before a sensor is opened for nothing.
  checkTransportOptions(options.listen, options.security);
  // gRPC starts its threads from threads at grpc_nice, so they inherit that lower priority
  // (grpc_init's timer threads with the first credentials, the server's when it starts); the
  // pipeline's threads start from this one and set their own priority.
  RpcServerOptions server_options;
  runAtNice(options.limits.grpc_nice, [&] {
    if (options.security.tokens()) {
      server_options.tokens =
          std::make_shared<const AccessTokens>(AccessTokens::load(options.security.token_file));
    }
    server_options.credentials = makeServerCredentials(options.security, server_options.tokens);
  });
  server_options.reflection = options.security.reflection;
  server_options.limits = options.limits;
  if (!options.record.root.empty()) {
    std::error_code error;
    std::filesystem::create_directories(options.record.root, error);
    if (error) {
      spdlog::warn("cannot create the recordings root {}: {}; Record will be refused",
                   options.record.root.string(), error.message());
    }
  }
  if (!options.object_models.empty()) {
    object_models_ =
        std::make_unique<ObjectModelStore>(options.object_models, options.object_models_max);
  }
  DetectorConfig detectors = options.detectors;
  if (options.find_taught_objects) {
    if (!object_models_) {
      throw std::invalid_argument(
          "the taught-object stage needs an object models folder (--object-models)");
    }
    detectors.taught_tracker_params.describe = object_models_->params();
    detectors.taught_models = [store = object_models_.get()] {
      std::vector<std::shared_ptr<const ObjectModel>> models;
      for (auto& stored : store->list()) models.push_back(std::move(stored.model));
      return models;
    };
  }
  DetectorChain chain = makeDetectorChain(detectors);
  pipeline_ = std::make_unique<Pipeline>(openSource(options.source, options.pacing, options.loop),
                                         std::move(chain), cache_, hub_, &tap_, options.pipeline);
  ServiceContext context{.cache = cache_, .hub = hub_};
  context.frame_tap = &tap_;
  context.pipeline_status = [pipeline = pipeline_.get()] { return pipeline->status(); };
  context.record = options.record;
  context.object_models = object_models_.get();
  runAtNice(options.limits.grpc_nice, [&] {
    server_ =
        std::make_unique<RpcServer>(options.listen, std::move(context), std::move(server_options));
  });
  pipeline_->start();
}

Daemon::~Daemon() { shutdown(); }

HealthVerdict Daemon::health() const {
  return judgePipelineHealth(pipeline_->progress(), std::chrono::steady_clock::now(), stall_limit_);
}

void Daemon::shutdown() {
  hub_.closeAll();
  server_->shutdown();
  pipeline_->stop();
}

}  // namespace shapesense
