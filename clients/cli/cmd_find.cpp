#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "commands.h"
#include "overlay.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {

void addFindCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("find", "Look for taught objects in the frame at T");
  struct Args {
    std::string at;
    std::vector<std::string> names;
    bool json = false;
    std::string overlay;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at, "T in seconds (default: the newest frame)");
  cmd->add_option("--names", args->names, "Objects to look for, a,b,c (default: every one)")
      ->delimiter(',');
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_option("--overlay", args->overlay,
                  "Write an overlay PNG: each found object's 3D box and name over the frame");
  cmd->callback([&global, args] {
    Connection connection(global);
    v1::FindObjectsRequest request;
    request.set_at_ns(parseTimeArgument(args->at));
    for (const auto& name : args->names) request.add_names(name);
    v1::FindObjectsResponse response;
    // Building the frame's surface takes tens of milliseconds, each model a few more.
    Connection::check(
        connection.stub().FindObjects(connection.context().get(), request, &response));
    if (!args->overlay.empty()) {
      auto background = fetchFrameBackground(connection, response.frame_timestamp_ns());
      for (const auto& detection : response.detections())
        drawObjectDetection(background.bgr, background.intrinsics, detection);
      writePng(args->overlay, background.bgr);
    }
    if (args->json) {
      std::cout << toJson(response) << "\n";
      return;
    }
    std::cout << "frame " << formatNsAsSeconds(response.frame_timestamp_ns()) << " (seq "
              << response.frame_sequence() << "): " << response.detections_size()
              << " objects found (" << response.compute_ms() << " ms)\n";
    if (response.detections_size() > 0) {
      std::printf("%-24s %6s %-26s %8s %s\n", "name", "score", "position (m)", "turn deg",
                  "image box");
    }
    for (const auto& d : response.detections()) {
      const auto& t = d.translation();
      char position[48];
      std::snprintf(position, sizeof position, "%.3f %.3f %.3f", t.x(), t.y(), t.z());
      const double turn_deg =
          2.0 * std::acos(std::min(1.0, std::abs(d.rotation().w()))) * 180.0 / M_PI;
      const auto& b = d.image_box();
      std::printf("%-24s %6.2f %-26s %8.1f %d,%d %dx%d\n", d.name().c_str(), d.score(), position,
                  turn_deg, b.x(), b.y(), b.width(), b.height());
    }
    if (!args->overlay.empty()) std::cout << "overlay written to " << args->overlay << "\n";
  });
}

}  // namespace shapesense::cli
