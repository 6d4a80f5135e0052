#include <cstdio>
#include <iostream>

#include "commands.h"
#include "shapesense/core/geometry/timestamp.h"

namespace shapesense::cli {

void addObjectsCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("objects", "The objects the daemon was taught (`teach`)");
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json, "Print JSON");
  cmd->callback([&global, json] {
    Connection connection(global);
    v1::ListObjectModelsResponse response;
    Connection::check(
        connection.stub().ListObjectModels(connection.context().get(), {}, &response));
    if (*json) {
      std::cout << toJson(response) << "\n";
      return;
    }
    std::cout << response.models_size() << " taught objects (at most " << response.max_models()
              << ")\n";
    if (response.models_size() > 0) {
      std::printf("%-24s %8s %8s %-22s %s\n", "name", "features", "points", "box (m)", "taught at");
    }
    for (const auto& model : response.models()) {
      char box[48];
      std::snprintf(box, sizeof box, "%.3f x %.3f x %.3f", model.box_size().x(),
                    model.box_size().y(), model.box_size().z());
      std::printf("%-24s %8u %8u %-22s %s\n", model.name().c_str(), model.feature_count(),
                  model.surface_points(), box, formatNsAsSeconds(model.taught_at_ns()).c_str());
    }
  });
}

}  // namespace shapesense::cli
