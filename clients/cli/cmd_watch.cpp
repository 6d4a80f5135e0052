#include <cstdio>
#include <iostream>

#include "commands.h"
#include "shapesense/core/geometry/timestamp.h"

namespace shapesense::cli {

void addWatchCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("watch", "Print a summary of every new frame until Ctrl-C");
  struct Args {
    bool json = false;
    unsigned count = 0;
  };
  auto args = std::make_shared<Args>();
  cmd->add_flag("--json", args->json, "Print one JSON object per line");
  cmd->add_option("--count", args->count, "Stop after N summaries (0 = never)");
  cmd->callback([&global, args] {
    // A channel of its own: a terminal that scrolls slowly should show the newest frames.
    const auto stub = v1::ShapeSense::NewStub(makeChannel(global, freshStreamArguments()));
    auto context = Connection::streamContext();
    auto reader = stub->Watch(context.get(), v1::WatchRequest{});
    readStream(*reader, *context, args->count, [&](const v1::FrameSummary& summary) {
      if (args->json) {
        std::cout << toJson(summary) << std::endl;
      } else {
        const auto& d = summary.depth_stats();
        std::printf("%s  seq %-6llu valid %5.1f%%  depth %.2f..%.2f m (median %.2f)",
                    formatNsAsSeconds(summary.info().timestamp_ns()).c_str(),
                    static_cast<unsigned long long>(summary.info().sequence()),
                    100 * d.valid_fraction(), d.min_m(), d.max_m(), d.median_m());
        std::printf("  %u planes  %u segments  %u bowls", summary.planes(), summary.segments(),
                    summary.bowls());
        if (summary.taught_objects() > 0)
          std::printf("  %u taught objects", summary.taught_objects());
        for (const auto& t : summary.timings())
          std::printf("  %s %.2f ms", t.stage().c_str(), t.ms());
        if (summary.dropped_before() > 0) {
          std::printf("  (%llu dropped)",
                      static_cast<unsigned long long>(summary.dropped_before()));
        }
        std::printf("\n");
        std::fflush(stdout);
      }
    });
  });
}

}  // namespace shapesense::cli
