#include <cmath>
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/synthetic_recording.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::cli {

void addSynthCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "synth",
      "Write a synthetic recording: TUM layout with its ground truth (truth/, truth.jsonl), or a "
      "fakenect dump (libfreenect's record format, 640x480, depth as raw disparity)");
  struct Args {
    std::uint64_t frames = 30;
    std::string out;
    std::uint64_t seed = 1;
    double fps = 30;
    std::string start = "1600000000";
    bool still = false;
    std::string format = "tum";
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--frames", args->frames, "Frames to render")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--out", args->out, "Output directory")->required();
  cmd->add_option("--seed", args->seed, "Scene seed (layout and noise)")->capture_default_str();
  cmd->add_option("--fps", args->fps, "Frame rate of the stamps")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--start", args->start, "Stamp of the first frame, seconds")
      ->capture_default_str();
  cmd->add_flag("--static", args->still, "Keep the camera still (default: it sways slowly)");
  cmd->add_option("--format", args->format,
                  "tum (replay with --source tum:DIR) or fakenect (--source fakenect:DIR, or "
                  "scripts/shapesensed-fakenect DIR for the real libfreenect path)")
      ->check(CLI::IsMember({"tum", "fakenect"}))
      ->capture_default_str();
  cmd->callback([args] {
    const auto start_ns = parseSecondsToNs(args->start);
    if (!start_ns || *start_ns <= 0)
      throw CLI::ValidationError("--start", "'" + args->start + "' is not a time in seconds");
    synthetic::SceneParams params;
    params.seed = args->seed;
    params.camera_motion = args->still ? 0.0 : 1.0;
    if (args->format == "fakenect") {
      if (std::filesystem::exists(args->out / std::filesystem::path("INDEX.txt"))) {
        throw std::runtime_error(
            args->out + " already holds a fakenect dump (INDEX.txt); choose a new directory");
      }
      params.frame_rate_hz = args->fps;
      const synthetic::SyntheticScene scene(params);
      FakenectDumpWriter writer(args->out);
      for (std::uint64_t i = 0; i < args->frames; ++i) {
        const TimestampNs stamp =
            *start_ns + std::llround(static_cast<double>(i) * 1e9 / args->fps);
        writer.write(scene.render(i, stamp).frame);
      }
    } else {
      synthetic::writeSyntheticRecording(args->out, params, args->frames, *start_ns, args->fps);
    }
    std::cout << args->frames << " synthetic frame(s) (seed " << args->seed << ") written to "
              << args->out << " as "
              << (args->format == "fakenect" ? "a fakenect dump" : "a TUM recording") << "\n";
  });
}

}  // namespace shapesense::cli
