// shapesensed: the shapesense daemon. See README.md and `shapesensed --help`.

#include <algorithm>
#include <chrono>
#include <csignal>
#include <ctime>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#ifdef SHAPESENSE_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/open_source.h"
#include "shapesense/server/daemon.h"
#include "shapesense/server/frame_memory.h"

namespace {

// Blocks SIGINT/SIGTERM in every thread (threads inherit the mask), so that only the main
// thread's sigwait() sees them and shutdown runs in ordinary code, not in a signal handler.
sigset_t blockShutdownSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

void notifySystemd([[maybe_unused]] const char* state) {
#ifdef SHAPESENSE_HAVE_SYSTEMD
  sd_notify(0, state);
#endif
}

/// The systemd watchdog interval (WatchdogSec=), or zero when systemd does not watch us.
std::chrono::microseconds watchdogInterval() {
  std::uint64_t usec = 0;
#ifdef SHAPESENSE_HAVE_SYSTEMD
  if (sd_watchdog_enabled(0, &usec) <= 0) usec = 0;
#endif
  return std::chrono::microseconds(usec);
}

/// Waits for SIGINT or SIGTERM. Meanwhile pets the systemd watchdog at half its interval while
/// the pipeline is healthy, and repeats the warning about an open remote API every minute.
int waitForShutdown(const sigset_t& signals, const shapesense::Daemon& daemon, bool insecure_remote,
                    const std::string& listen) {
  using Clock = std::chrono::steady_clock;
  constexpr auto kInsecureWarningPeriod = std::chrono::minutes(1);
  const auto pet_period = watchdogInterval() / 2;
  const auto never = Clock::time_point::max();
  auto next_warning = insecure_remote ? Clock::now() : never;
  auto next_pet = pet_period.count() > 0 ? Clock::now() : never;
  bool healthy = true;
  while (true) {
    const auto now = Clock::now();
    if (now >= next_warning) {
      spdlog::warn(
          "--insecure-remote: {} serves the whole API without encryption or authentication to "
          "anyone who can reach it",
          listen);
      next_warning = now + kInsecureWarningPeriod;
    }
    if (now >= next_pet) {
      const shapesense::HealthVerdict verdict = daemon.health();
      if (verdict.healthy) {
        notifySystemd("WATCHDOG=1");
        if (!healthy) spdlog::info("the pipeline moves again; petting the watchdog");
      } else if (healthy) {
        spdlog::error("{}: the pipeline hangs; no longer petting the systemd watchdog",
                      verdict.reason);
      }
      healthy = verdict.healthy;
      next_pet = now + pet_period;
    }
    const auto wake = std::min(next_warning, next_pet);
    int signal_number = 0;
    if (wake == never) {
      sigwait(&signals, &signal_number);
      return signal_number;
    }
    const auto wait = std::max(Clock::duration::zero(), wake - Clock::now());
    const auto wait_s = std::chrono::duration_cast<std::chrono::seconds>(wait);
    const timespec timeout{
        static_cast<std::time_t>(wait_s.count()),
        static_cast<long>(
            std::chrono::duration_cast<std::chrono::nanoseconds>(wait - wait_s).count())};
    signal_number = sigtimedwait(&signals, nullptr, &timeout);
    if (signal_number > 0) return signal_number;
  }
}

}  // namespace

using shapesense::DaemonOptions;

namespace {

/// Option values that are not DaemonOptions fields as such: parsed into these, then converted.
struct CommandLine {
  DaemonOptions options;
  std::string rate = "recorded";
  std::string record_root = shapesense::defaultRecordRoot().string();
  std::uint64_t record_min_free_mb = options.record.min_free_bytes >> 20;
  std::string segmentation{
      shapesense::formatSegmentationMethod(shapesense::kDefaultSegmentationMethod)};
  std::string planes = "hough";
  std::string bowls = "on";
  std::string taught_objects = "off";
  std::vector<double> bowl_rim_cm = {
      100 * options.detectors.bowl_geometry_params.min_rim_diameter_m,
      100 * options.detectors.bowl_geometry_params.max_rim_diameter_m};
  std::string models;
  std::string object_models = shapesense::defaultObjectModelsDir().string();
  double stall_seconds = std::chrono::duration<double>(options.stall_limit).count();
  int query_max_wait_ms = static_cast<int>(options.limits.queries.max_wait.count());
  double keepalive_seconds = options.limits.keepalive_ms / 1000.0;
  double keepalive_timeout_seconds = options.limits.keepalive_timeout_ms / 1000.0;
  std::string check_fakenect;
  std::string log_level = "info";
};

void addSourceOptions(CLI::App& app, CommandLine& c) {
  DaemonOptions& options = c.options;
  std::string& rate = c.rate;
  app.add_option("--source", options.source,
                 std::string("Frame source: ") + shapesense::kSourceSpecs +
                     " (tum: a TUM RGB-D recording, fakenect: a libfreenect dump)")
      ->capture_default_str();
  app.add_option("--rate", rate,
                 "Replay pacing: recorded (real time) or max (as fast as processed)")
      ->check(CLI::IsMember({"recorded", "max"}))
      ->capture_default_str();
  app.add_flag("--loop", options.loop,
               "Replay: start again at the end (timestamps keep increasing)");
  app.add_option("--cache-frames", options.cache_frames, "Frames kept in the cache")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--listen", options.listen,
                 "gRPC listen address; one other machines can reach needs TLS and tokens, or "
                 "--insecure-remote")
      ->capture_default_str();
}

void addSecurityOptions(CLI::App& app, CommandLine& c) {
  DaemonOptions& options = c.options;
  shapesense::TransportSecurity& security = options.security;
  app.add_option("--tls-cert", security.tls_cert,
                 "TLS: the server's PEM certificate chain (with --tls-key)");
  app.add_option("--tls-key", security.tls_key, "TLS: the server's PEM private key");
  app.add_option("--tls-client-ca", security.tls_client_ca,
                 "TLS: also require client certificates signed by this PEM CA bundle");
  app.add_option("--token-file", security.token_file,
                 "Bearer tokens, one `NAME ROLE TOKEN` a line (ROLE: read or record); the file "
                 "must be readable only by the daemon's user; needs TLS");
  app.add_flag("--insecure-remote", security.insecure_remote,
               "Allow a non-loopback --listen without TLS and tokens (warns every minute)");
  app.add_flag("--reflection", security.reflection,
               "Serve gRPC server reflection (lists the whole API)");
}

void addRecordOptions(CLI::App& app, CommandLine& c) {
  DaemonOptions& options = c.options;
  app.add_option("--record-root", c.record_root,
                 "Directory the Record RPC writes under; clients name recordings relative to it")
      ->capture_default_str();
  app.add_option("--record-min-free-mb", c.record_min_free_mb,
                 "Record stops (and does not start) when the recordings' file system has less "
                 "free space, in MB")
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1} << 30))
      ->capture_default_str();
  app.add_option("--record-max-seconds", options.record.max_seconds,
                 "Longest recording a client may ask for")
      ->check(CLI::Range(1.0, 86400.0))
      ->capture_default_str();
}

void addObjectModelOptions(CLI::App& app, CommandLine& c) {
  app.add_option("--object-models", c.object_models,
                 "Folder of the taught objects (<name>.json, written by TeachObject; created "
                 "when missing); default: object-models beside the default recordings root")
      ->capture_default_str();
  app.add_option("--object-models-max", c.options.object_models_max,
                 "Most taught objects the folder may hold; TeachObject answers "
                 "RESOURCE_EXHAUSTED beyond")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1000}))
      ->capture_default_str();
  app.add_option("--taught-objects", c.taught_objects,
                 "Look for the taught objects on every frame and follow them from frame to frame "
                 "(WatchScene and GetScene carry them): on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--taught-searches-per-frame",
                 c.options.detectors.taught_tracker_params.searches_per_frame,
                 "With --taught-objects on: taught objects not in view that are searched for in "
                 "one frame, in turn (each search costs the whole frame's features and tens of "
                 "milliseconds); 0 = all of them, every frame")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
}

void addDetectorOptions(CLI::App& app, CommandLine& c) {
  app.add_option("--segmentation", c.segmentation,
                 "Segmentation run on every frame: " + shapesense::listSegmentationMethods(", ") +
                     " or none")
      ->check(CLI::IsMember([] {
        auto choices = shapesense::segmentationMethodNames();
        choices.emplace_back("none");
        return choices;
      }()))
      ->capture_default_str();
  app.add_option("--planes", c.planes, "Plane detector run on every frame: hough, ransac or none")
      ->check(CLI::IsMember({"hough", "ransac", "none"}))
      ->capture_default_str();
  app.add_option("--bowls", c.bowls,
                 "Bowl detector run on every frame (needs the models of --models): on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--bowl-rim-cm", c.bowl_rim_cm,
                 "Rim diameters a reported bowl may have, MIN,MAX in centimetres (the 3D check "
                 "of every detection)")
      ->expected(2)
      ->delimiter(',')
      ->check(CLI::Range(1.0, 200.0))
      ->capture_default_str();
  app.add_option("--models", c.models,
                 "Folder of the bowl models (bowl_*.json); default: " +
                     shapesense::defaultBowlModelsDir().string());
}

void addHealthAndLimitOptions(CLI::App& app, CommandLine& c) {
  DaemonOptions& options = c.options;
  app.add_option("--watchdog-stall-seconds", c.stall_seconds,
                 "Under a systemd watchdog (WatchdogSec=): stop petting it when a streaming "
                 "source has delivered nothing, or the detectors have worked on one frame, for "
                 "this long")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  shapesense::ServerLimits& limits = options.limits;
  app.add_option("--query-workers", limits.queries.workers,
                 "Threads for EstimateBox, GetFrame and the detector queries; 0 = one fewer "
                 "than the cores (" +
                     std::to_string(shapesense::QueryPool::defaultWorkers()) +
                     " here), so the detectors keep a core")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  app.add_option("--query-queue", limits.queries.queue,
                 "Such queries that may wait for a worker; more are answered RESOURCE_EXHAUSTED")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  app.add_option("--query-max-wait-ms", c.query_max_wait_ms,
                 "Such a query that waited this long for a worker is answered "
                 "RESOURCE_EXHAUSTED instead of being run late")
      ->check(CLI::Range(1, 60000))
      ->capture_default_str();
  app.add_option("--query-nice", limits.queries.nice,
                 "Nice value of the query workers (0-19), so the detectors win a busy core")
      ->check(CLI::Range(0, 19))
      ->capture_default_str();
  app.add_option("--grpc-nice", limits.grpc_nice,
                 "Nice value of gRPC's threads (0-19), which receive, refuse and write every "
                 "call, so a flood of calls takes time from them before the detectors")
      ->check(CLI::Range(0, 19))
      ->capture_default_str();
  app.add_option("--busy-pushback-ms", limits.busy_pushback_ms,
                 "Calls refused RESOURCE_EXHAUSTED tell the client to wait this long before "
                 "calling again (gRPC's grpc-retry-pushback-ms; 0 = say nothing)")
      ->check(CLI::Range(0, 60000))
      ->capture_default_str();
  app.add_option("--pipeline-nice", options.pipeline.thread_nice,
                 "Nice value of the capture and detector threads (-20-0); below 0 they come "
                 "before clients on the same machine, where the system allows it (root, "
                 "CAP_SYS_NICE or the unit's LimitNICE=)")
      ->check(CLI::Range(-20, 0))
      ->capture_default_str();
  app.add_option("--max-calls", limits.max_calls,
                 "Calls (other than Watch and Record) answered at once, queued ones included; "
                 "more are answered RESOURCE_EXHAUSTED")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--max-watch-per-client", limits.max_watch_per_client,
                 "Watch streams one client (address without port) may have open")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--max-watch-streams", limits.max_watch_streams,
                 "Watch streams of all clients together")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--max-message-bytes", limits.max_receive_message_bytes,
                 "Largest request the daemon reads")
      ->check(CLI::Range(1024, 64 << 20))
      ->capture_default_str();
  app.add_option("--max-streams-per-connection", limits.max_streams_per_connection,
                 "Calls one connection may have open at once (HTTP/2 streams)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--keepalive-seconds", c.keepalive_seconds,
                 "Ping a connection idle this long; one that does not answer within "
                 "--keepalive-timeout-seconds is closed with its streams")
      ->check(CLI::Range(1.0, 86400.0))
      ->capture_default_str();
  app.add_option("--keepalive-timeout-seconds", c.keepalive_timeout_seconds,
                 "How long a keepalive ping may go unanswered")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
}

void addToolOptions(CLI::App& app, CommandLine& c) {
  app.add_option(
      "--check-fakenect", c.check_fakenect,
      "Only check that DIR is a fakenect dump Debian's fakenect library can replay, print "
      "its problems and exit (0 = usable); used by scripts/shapesensed-fakenect");
  app.add_option("--log-level", c.log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
}

/// The parsed values as DaemonOptions; nullopt (after saying why) when they contradict.
std::optional<DaemonOptions> toDaemonOptions(CommandLine c) {
  DaemonOptions& options = c.options;
  options.pacing =
      c.rate == "max" ? shapesense::Pacing::kAsFastAsPossible : shapesense::Pacing::kRecorded;
  options.detectors.segmentation =
      shapesense::parseSegmentationMethod(c.segmentation);              // none -> off
  options.detectors.planes = shapesense::parsePlaneDetector(c.planes);  // none -> off
  options.detectors.bowls = c.bowls == "on";
  options.detectors.bowl_models = c.models;  // empty -> the default folder
  if (c.bowl_rim_cm[0] >= c.bowl_rim_cm[1]) {
    std::cerr << "--bowl-rim-cm: MIN must be below MAX\n";
    return std::nullopt;
  }
  options.detectors.bowl_geometry_params.min_rim_diameter_m = c.bowl_rim_cm[0] / 100;
  options.detectors.bowl_geometry_params.max_rim_diameter_m = c.bowl_rim_cm[1] / 100;
  options.stall_limit = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(c.stall_seconds));
  options.limits.queries.max_wait = std::chrono::milliseconds(c.query_max_wait_ms);
  options.limits.keepalive_ms = static_cast<int>(c.keepalive_seconds * 1000);
  options.limits.keepalive_timeout_ms = static_cast<int>(c.keepalive_timeout_seconds * 1000);
  options.record.root = c.record_root;
  options.record.min_free_bytes = c.record_min_free_mb << 20;
  if (c.object_models.empty()) {
    std::cerr << "--object-models: name a folder\n";
    return std::nullopt;
  }
  options.object_models = c.object_models;
  options.find_taught_objects = c.taught_objects == "on";
  return options;
}

int checkFakenectDump(const std::string& dir) {
  const auto problems = shapesense::validateFakenectDump(dir);
  for (const auto& problem : problems) std::cerr << problem << "\n";
  if (problems.empty()) std::cout << dir << ": a usable fakenect dump\n";
  return problems.empty() ? 0 : 1;
}

/// Runs the daemon until SIGINT or SIGTERM; the exit code.
int serve(const DaemonOptions& options) {
  const sigset_t signals = blockShutdownSignals();
  std::unique_ptr<shapesense::Daemon> daemon;
  try {
    daemon = std::make_unique<shapesense::Daemon>(options);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  const auto& security = options.security;
  spdlog::info(
      "shapesensed {} serving {} on {} (port {}, {}{}); recordings under {}; taught objects in {}",
      SHAPESENSE_VERSION, options.source, options.listen, daemon->port(),
      security.tls() ? "TLS" : "plain", security.tokens() ? " with tokens" : "",
      options.record.root.string(), options.object_models.string());
  notifySystemd("READY=1");

  const int signal_number = waitForShutdown(
      signals, *daemon, shapesense::servesInsecureRemote(options.listen, options.security),
      options.listen);
  spdlog::info("{} received; shutting down", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
  notifySystemd("STOPPING=1");
  daemon->shutdown();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CommandLine command_line;
  CLI::App app{
      "shapesensed: RGB-D perception daemon. Serves frames and detector results over gRPC."};
  app.set_config("--config", "", "Read options from a TOML file (keys as the long option names)");
  // A misspelt key would otherwise be dropped without a word, and the daemon run on a default
  // the operator meant to change.
  app.allow_config_extras(CLI::config_extras_mode::error);
  addSourceOptions(app, command_line);
  addSecurityOptions(app, command_line);
  addRecordOptions(app, command_line);
  addDetectorOptions(app, command_line);
  addObjectModelOptions(app, command_line);
  addHealthAndLimitOptions(app, command_line);
  addToolOptions(app, command_line);
  CLI11_PARSE(app, argc, argv);
  if (!command_line.check_fakenect.empty()) return checkFakenectDump(command_line.check_fakenect);
  spdlog::set_level(spdlog::level::from_str(command_line.log_level));
  const std::optional<DaemonOptions> options = toDaemonOptions(command_line);
  if (!options) return 2;
  if (!shapesense::keepFrameBuffersAllocated())
    spdlog::warn("the C library refused to keep frame buffers allocated between frames");
  return serve(*options);
}
