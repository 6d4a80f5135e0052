#include <iostream>

#include "analyze.h"
#include "commands.h"
#include "shapesense/core/segmentation/segmentation.h"

namespace shapesense::cli {

void addAnalyzeCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "analyze", "Run the detectors on a recording without a daemon; writes DIR/results.jsonl");
  struct Args {
    std::string source;
    std::string out;
    bool quiet = false;
    std::string segmentation{formatSegmentationMethod(kDefaultSegmentationMethod)};
    std::string planes = "hough";
    std::string bowls = "on";
    std::string models;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("SOURCE", args->source, "Recording directory (TUM layout), or tum:DIR")
      ->required();
  cmd->add_option("--out", args->out, "Output directory")->required();
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->add_option("--segmentation", args->segmentation,
                  "Segmentation method: " + listSegmentationMethods(", ") + " or none")
      ->check(CLI::IsMember([] {
        auto choices = segmentationMethodNames();
        choices.emplace_back("none");
        return choices;
      }()))
      ->capture_default_str();
  cmd->add_option("--planes", args->planes, "Plane detector: hough, ransac or none")
      ->check(CLI::IsMember({"hough", "ransac", "none"}))
      ->capture_default_str();
  cmd->add_option("--bowls", args->bowls, "Bowl detector: on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_option(
      "--models", args->models,
      "Folder of the bowl models (bowl_*.json); default: " + defaultBowlModelsDir().string());
  cmd->callback([args] {
    std::string dir = args->source;
    if (dir.rfind("tum:", 0) == 0) dir = dir.substr(4);
    DetectorConfig config;
    config.segmentation = parseSegmentationMethod(args->segmentation);  // none -> off
    config.planes = parsePlaneDetector(args->planes);                   // none -> off
    config.bowls = args->bowls == "on";
    config.bowl_models = args->models;  // empty -> the default folder
    const DetectorChain chain = makeDetectorChain(config);
    const auto summary =
        analyzeRecording(dir, args->out, chain, [&](std::size_t done, std::size_t total) {
          if (!args->quiet)
            std::cerr << "\ranalyze: " << done << "/" << total << " frames" << std::flush;
        });
    if (!args->quiet) std::cerr << "\n";
    std::cout << summary.frames << " frame(s) analysed, " << summary.bad_frames
              << " unreadable; results in "
              << (std::filesystem::path(args->out) / "results.jsonl").string() << "\n";
  });
}

}  // namespace shapesense::cli
