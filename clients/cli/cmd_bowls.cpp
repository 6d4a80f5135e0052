#include <cstdio>
#include <iostream>

#include "commands.h"
#include "overlay.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {
void addBowlsCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("bowls", "The bowls found in the frame at T, with their 3D boxes");
  struct Args {
    std::string at;
    bool json = false;
    std::string out;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at,
                  "T in seconds (default: the newest frame the detectors processed)");
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_option("--out", args->out,
                  "Write an overlay PNG: boxes, scores and views over the frame");
  cmd->callback([&global, args] {
    Connection connection(global);
    v1::GetBowlsRequest request;
    request.set_at_ns(args->at.empty() ? connection.newestProcessedFrame()
                                       : parseTimeArgument(args->at));
    v1::GetBowlsResponse response;
    Connection::check(connection.stub().GetBowls(connection.context().get(), request, &response));
    if (!args->out.empty()) {
      auto background = fetchFrameBackground(connection, response.info().timestamp_ns());
      for (const auto& bowl : response.bowls())
        drawBowl(background.bgr, background.intrinsics, bowl);
      writePng(args->out, background.bgr);
    }
    if (args->json) {
      std::cout << toJson(response) << "\n";
      return;
    }
    std::cout << "frame " << formatNsAsSeconds(response.info().timestamp_ns()) << " (seq "
              << response.info().sequence() << "): " << response.bowls_size() << " bowls ("
              << response.compute_ms() << " ms)\n";
    if (response.bowls_size() > 0) {
      std::printf("%3s %6s %-6s %-18s %-14s %s\n", "#", "score", "view", "box", "rim/height cm",
                  "3D box centre (m)");
    }
    for (int i = 0; i < response.bowls_size(); ++i) {
      const auto& bowl = response.bowls(i);
      const auto& b = bowl.box();
      char box[32];
      std::snprintf(box, sizeof box, "%d,%d %dx%d", b.x(), b.y(), b.width(), b.height());
      char size[32] = "-";  // a confident detection the depth could not settle has no rim
      if (bowl.rim_diameter_m() > 0)
        std::snprintf(size, sizeof size, "%.1f/%.1f", 100 * bowl.rim_diameter_m(),
                      100 * bowl.height_m());
      std::printf("%3d %6.1f %-6s %-18s %-14s", i, bowl.score(), bowl.view().c_str(), box, size);
      if (bowl.corners_size() == 8) {
        // Opposite corners 0 (front top-left) and 6 (back bottom-right) average to the centre.
        const auto& a = bowl.corners(0);
        const auto& c = bowl.corners(6);
        std::printf(" %7.3f %7.3f %7.3f\n", (a.x() + c.x()) / 2, (a.y() + c.y()) / 2,
                    (a.z() + c.z()) / 2);
      } else {
        std::printf(" (no depth in the box)\n");
      }
    }
    if (!args->out.empty()) std::cout << "overlay written to " << args->out << "\n";
  });
}

}  // namespace shapesense::cli
