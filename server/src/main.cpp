// shapesensed: the shapesense daemon. See README.md and `shapesensed --help`.

#include <csignal>
#include <iostream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#ifdef SHAPESENSE_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/server/daemon.h"

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

}  // namespace

int main(int argc, char** argv) {
  using shapesense::DaemonOptions;
  DaemonOptions options;
  CLI::App app{
      "shapesensed: RGB-D perception daemon. Serves frames and detector results over gRPC."};
  app.set_config("--config", "", "Read options from a TOML file (keys as the long option names)");
  app.add_option("--source", options.source,
                 "Frame source: synthetic[:SEED], tum:DIR (a TUM RGB-D recording), "
                 "freenect[:SERIAL|INDEX], "
                 "openni2[:URI] or fakenect:DIR (a fakenect dump)")
      ->capture_default_str();
  std::string rate = "recorded";
  app.add_option("--rate", rate,
                 "Replay pacing: recorded (real time) or max (as fast as processed)")
      ->check(CLI::IsMember({"recorded", "max"}))
      ->capture_default_str();
  app.add_flag("--loop", options.loop,
               "Replay: start again at the end (timestamps keep increasing)");
  app.add_option("--cache-frames", options.cache_frames, "Frames kept in the cache")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--listen", options.listen, "gRPC listen address")->capture_default_str();
  std::string segmentation = "depth_step";
  app.add_option("--segmentation", segmentation,
                 "Segmentation run on every frame: depth_step, normal_edges, fused, "
                 "plane_prediction, tiled_ransac or none")
      ->check(CLI::IsMember(
          {"depth_step", "normal_edges", "fused", "plane_prediction", "tiled_ransac", "none"}))
      ->capture_default_str();
  std::string planes = "hough";
  app.add_option("--planes", planes, "Plane detector run on every frame: hough, ransac or none")
      ->check(CLI::IsMember({"hough", "ransac", "none"}))
      ->capture_default_str();
  std::string bowls = "on";
  app.add_option("--bowls", bowls,
                 "Bowl detector run on every frame (needs the models of --models): on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  std::string models;
  app.add_option("--models", models,
                 "Folder of the bowl models (bowl_*.json); default: " +
                     shapesense::defaultBowlModelsDir().string());
  std::string check_fakenect;
  app.add_option(
      "--check-fakenect", check_fakenect,
      "Only check that DIR is a fakenect dump Debian's fakenect library can replay, print "
      "its problems and exit (0 = usable); used by scripts/shapesensed-fakenect");
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (!check_fakenect.empty()) {
    const auto problems = shapesense::validateFakenectDump(check_fakenect);
    for (const auto& problem : problems) std::cerr << problem << "\n";
    if (problems.empty()) std::cout << check_fakenect << ": a usable fakenect dump\n";
    return problems.empty() ? 0 : 1;
  }
  options.pacing =
      rate == "max" ? shapesense::Pacing::kAsFastAsPossible : shapesense::Pacing::kRecorded;
  spdlog::set_level(spdlog::level::from_str(log_level));
  options.detectors.segmentation =
      shapesense::parseSegmentationMethod(segmentation);              // none -> off
  options.detectors.planes = shapesense::parsePlaneDetector(planes);  // none -> off
  options.detectors.bowls = bowls == "on";
  options.detectors.bowl_models = models;  // empty -> the default folder

  const sigset_t signals = blockShutdownSignals();
  std::unique_ptr<shapesense::Daemon> daemon;
  try {
    daemon = std::make_unique<shapesense::Daemon>(options);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  spdlog::info("shapesensed {} serving {} on {} (port {})", SHAPESENSE_VERSION, options.source,
               options.listen, daemon->port());
  notifySystemd("READY=1");

  int signal_number = 0;
  sigwait(&signals, &signal_number);
  spdlog::info("{} received; shutting down", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
  notifySystemd("STOPPING=1");
  daemon->shutdown();
  return 0;
}
