#include <cstdio>
#include <iostream>

#include "commands.h"
#include "roi_arg.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {

void addTeachCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand(
      "teach", "Teach the object an ROI marks in the frame at T, so that `find` finds it again");
  struct Args {
    std::string at;
    std::string roi;
    std::string name;
    bool replace = false;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at,
                  "T in seconds (default: the newest frame the detectors processed)");
  cmd->add_option("--roi", args->roi,
                  "Two opposite corners x1,y1,x2,y2 in pixels (inclusive) around the object: "
                  "the object is what `bbox --mode 4` boxes")
      ->required();
  cmd->add_option("--name", args->name, "The object's name: 1-64 letters, digits, '-', '_' or '.'")
      ->required();
  cmd->add_flag("--replace", args->replace, "Replace a taught object of that name");
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->callback([&global, args] {
    const auto [p1, p2] = parseRoiArgument(args->roi);
    Connection connection(global);
    v1::TeachObjectRequest request;
    // Teaching needs the detectors' segments: without --at, the newest frame they processed.
    request.set_at_ns(args->at.empty() ? connection.newestProcessedFrame()
                                       : parseTimeArgument(args->at));
    *request.mutable_p1() = p1;
    *request.mutable_p2() = p2;
    request.set_name(args->name);
    request.set_replace(args->replace);
    v1::TeachObjectResponse response;
    Connection::check(
        connection.stub().TeachObject(connection.context().get(), request, &response));
    if (args->json) {
      std::cout << toJson(response) << "\n";
      return;
    }
    const auto& model = response.model();
    std::printf(
        "%s %s from frame %s (seq %llu): %u features, %u surface points, box %.3f x "
        "%.3f x %.3f m\n",
        response.replaced() ? "replaced" : "taught", model.name().c_str(),
        formatNsAsSeconds(response.frame_timestamp_ns()).c_str(),
        static_cast<unsigned long long>(response.frame_sequence()), model.feature_count(),
        model.surface_points(), model.box_size().x(), model.box_size().y(), model.box_size().z());
  });
}

}  // namespace shapesense::cli
