#include <iostream>

#include "commands.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {

void addFramesCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("frames", "List the cached frames, oldest first");
  struct Args {
    bool json = false;
    std::string from, to;
    unsigned limit = 0;
  };
  auto args = std::make_shared<Args>();
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_option("--from", args->from, "Only frames captured at or after T (seconds)");
  cmd->add_option("--to", args->to, "Only frames captured at or before T (seconds)");
  cmd->add_option("--limit", args->limit, "At most N frames, the newest of the range");
  cmd->callback([&global, args] {
    v1::ListFramesRequest request;
    request.set_from_ns(parseTimeArgument(args->from));
    request.set_to_ns(parseTimeArgument(args->to));
    request.set_limit(args->limit);
    Connection connection(global);
    v1::ListFramesResponse response;
    Connection::check(connection.stub().ListFrames(connection.context().get(), request, &response));
    if (args->json) {
      std::cout << toJson(response) << "\n";
      return;
    }
    for (const auto& f : response.frames()) {
      std::cout << formatNsAsSeconds(f.timestamp_ns()) << "  seq " << f.sequence() << "  "
                << f.width() << "x" << f.height() << (f.has_rgb() ? "  rgb" : "")
                << (f.processed() ? "  processed" : "") << "\n";
    }
    std::cout << response.frames_size() << " frame(s) of " << response.cache().frames()
              << " cached\n";
  });
}

}  // namespace shapesense::cli
