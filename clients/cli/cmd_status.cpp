#include <cstdio>
#include <iostream>
#include <span>

#include "commands.h"
#include "shapesense/core/geometry/order_statistics.h"
#include "shapesense/core/geometry/timestamp.h"

namespace shapesense::cli {

void addStatusCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand(
      "status",
      "Source, counters, cached range, stage latencies and how long the daemon took to answer "
      "calls");
  auto json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *json, "Print JSON");
  cmd->callback([&global, json] {
    Connection connection(global);
    v1::GetStatusResponse status;
    Connection::check(connection.stub().GetStatus(connection.context().get(), {}, &status));
    if (*json) {
      std::cout << toJson(status) << "\n";
      return;
    }
    const auto& cache = status.cache();
    std::cout << "shapesensed " << status.version() << ", up "
              << static_cast<long>(status.uptime_s()) << " s\n"
              << "source     " << status.source() << " ("
              << v1::GetStatusResponse::SourceState_Name(status.source_state()) << ")\n";
    if (status.source_live()) {
      std::cout << "sensor     "
                << (status.source_connected() ? "connected" : "not connected (reconnecting)")
                << ", lost " << status.source_disconnects() << " time(s), "
                << status.source_reconnects() << " reconnect(s), " << status.source_dropped_frames()
                << " frame(s) dropped by the driver\n";
    }
    if (!status.source_message().empty())
      std::cout << "last error " << status.source_message() << "\n";
    std::cout << "frames     " << status.frames_received() << " received, "
              << status.frames_processed() << " processed, " << status.frames_skipped()
              << " skipped, " << status.source_errors() << " source errors";
    if (status.frames_out_of_order() > 0)
      std::cout << ", " << status.frames_out_of_order() << " dropped out of order";
    std::cout << "\n"
              << "cache      " << cache.frames() << "/" << cache.capacity() << " frames";
    if (cache.frames() > 0) {
      std::cout << ", " << formatNsAsSeconds(cache.oldest_ns()) << " .. "
                << formatNsAsSeconds(cache.newest_ns()) << " s";
    }
    std::cout << "\n";
    if (status.stages_size() > 0) {
      std::printf("%-14s %8s %9s %9s %9s\n", "stage", "runs", "last ms", "median", "p95");
      for (const auto& s : status.stages()) {
        std::printf("%-14s %8llu %9.2f %9.2f %9.2f\n", s.stage().c_str(),
                    static_cast<unsigned long long>(s.runs()), s.last_ms(), s.median_ms(),
                    s.p95_ms());
      }
    }
    if (status.calls_size() > 0) {
      std::printf("%-18s %9s %9s %7s %10s %10s\n", "calls since start", "answered", "refused",
                  "failed", "p50 ms <=", "p99 ms <=");
      for (const auto& c : status.calls()) {
        const auto p = [&c](double q) {
          return bucketQuantile(
              std::span(c.bucket_upper_ms().data(), c.bucket_upper_ms().size()),
              std::span(c.answered_by_bucket().data(), c.answered_by_bucket().size()), q);
        };
        std::printf("%-18s %9llu %9llu %7llu %10g %10g\n", c.method().c_str(),
                    static_cast<unsigned long long>(c.answered()),
                    static_cast<unsigned long long>(c.refused()),
                    static_cast<unsigned long long>(c.failed()), p(0.5), p(0.99));
      }
    }
  });
}

}  // namespace shapesense::cli
