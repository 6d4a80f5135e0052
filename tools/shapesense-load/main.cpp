// shapesense-load: load and soak test of a running daemon. N clients send mixed queries
// (EstimateBox 80% for the newest frame, GetBowls 10% and GetPlanes 10% for the newest frame
// the detectors processed, which a Watch stream of the tool's own tracks) as fast as they are
// answered; a client refused with RESOURCE_EXHAUSTED waits as long as the daemon's retry
// pushback says (grpc-retry-pushback-ms), or --backoff-ms when it says nothing or with
// --ignore-pushback, as a well-behaved client would. M slow subscribers read Watch one summary per
// --slow-read-ms, for --seconds. At the end it prints requests per second, latency
// percentiles per method (answered calls), refusals and other errors by status code, the
// daemon's skipped frames over the run, what the slow subscribers saw (dropped_before, and how
// many frames behind the newest each summary was when read), the daemon's resident memory
// at start and end (with --daemon-pid), and the daemon's own latencies for the run (GetStatus
// calls): on one machine the tool's threads compete with the daemon's, and the latencies this
// tool sees include its own wait for a core.
//
//   build/tools/shapesense-load --server 127.0.0.1:50551 --clients 64 --slow-watchers 16
//       --seconds 600 --daemon-pid "$(pidof shapesensed)"   (one command line)
//
// Each client and subscriber has its own connection. Only for a daemon on this machine or a test
// network: every request loop is bounded by --seconds.
#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <grpcpp/support/channel_arguments.h>
#include <CLI/CLI.hpp>

#include "commands.h"
#include "connection.h"
#include "shapesense/core/geometry/order_statistics.h"

namespace {

using Clock = std::chrono::steady_clock;

/// gRPC deadlines are wall-clock times.
std::chrono::system_clock::time_point deadlineAt(Clock::time_point when) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(when - Clock::now());
}
namespace v1 = shapesense::v1;

struct LoadOptions {
  int clients = 64;
  int slow_watchers = 16;
  double seconds = 60;
  int slow_read_ms = 1000;
  int daemon_pid = 0;
  int backoff_ms = 5;
  bool ignore_pushback = false;
};

/// The newest frame the detectors processed, as the tool's own Watch stream last saw it.
struct Newest {
  std::atomic<std::int64_t> timestamp_ns{0};
  std::atomic<std::uint64_t> sequence{0};
};

/// What one client thread measured.
struct ClientStats {
  std::map<std::string, std::vector<double>> latency_ms;  ///< by method, successful calls
  std::map<grpc::StatusCode, std::uint64_t> errors;
  std::map<std::string, std::vector<double>> error_ms;  ///< by status code name
  /// From a query's first attempt to its answer, the refusals and waits before it included:
  /// what the client's user waits for.
  std::vector<double> to_answer_ms;
};

struct WatcherStats {
  std::uint64_t summaries = 0;
  std::uint64_t dropped_before = 0;  ///< sum of the stream's dropped_before
  std::uint64_t with_drops = 0;      ///< summaries with dropped_before > 0
  std::vector<double> behind;        ///< frames between each summary read and the newest
  grpc::StatusCode end = grpc::StatusCode::OK;
};

/// VmRSS of a process in MiB, or -1.
double residentMiB(int pid) {
  if (pid <= 0) return -1;
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      double kib = 0;
      status >> kib;
      return kib / 1024.0;
    }
    status.ignore(1 << 20, '\n');
  }
  return -1;
}

v1::GetStatusResponse daemonStatus(v1::ShapeSense::Stub& stub) {
  grpc::ClientContext context;
  context.set_deadline(deadlineAt(Clock::now() + std::chrono::seconds(10)));
  v1::GetStatusResponse status;
  const auto result = stub.GetStatus(&context, v1::GetStatusRequest(), &status);
  if (!result.ok()) throw shapesense::cli::RpcError(result);
  return status;
}

/// The daemon's own account of the run: its call latencies at the end minus those at the start.
std::map<std::string, v1::CallLatency> callsDuringRun(const v1::GetStatusResponse& start,
                                                      const v1::GetStatusResponse& end) {
  std::map<std::string, v1::CallLatency> run;
  for (const auto& call : end.calls()) run[call.method()] = call;
  for (const auto& call : start.calls()) {
    auto found = run.find(call.method());
    if (found == run.end()) continue;
    v1::CallLatency& diff = found->second;
    diff.set_answered(diff.answered() - call.answered());
    diff.set_refused(diff.refused() - call.refused());
    diff.set_failed(diff.failed() - call.failed());
    for (int i = 0; i < diff.answered_by_bucket_size() && i < call.answered_by_bucket_size(); ++i)
      diff.set_answered_by_bucket(i, diff.answered_by_bucket(i) - call.answered_by_bucket(i));
  }
  return run;
}

void reportDaemonSide(const std::map<std::string, v1::CallLatency>& calls) {
  std::printf(
      "daemon side (arrival to answer, without the network and this tool's own scheduling; "
      "bucket upper bounds):\n");
  for (const auto& [method, call] : calls) {
    const std::span bounds(call.bucket_upper_ms().data(), call.bucket_upper_ms().size());
    const std::span counts(call.answered_by_bucket().data(), call.answered_by_bucket().size());
    if (call.answered() + call.refused() + call.failed() == 0) continue;
    std::uint64_t within_10 = 0;
    for (std::size_t i = 0; i < counts.size() && i < bounds.size() && bounds[i] <= 10; ++i)
      within_10 += counts[i];
    std::printf(
        "  %-12s answered %llu (%.2f%% within 10 ms), refused %llu, failed %llu, p50 <= %g, "
        "p99 <= %g ms\n",
        method.c_str(), static_cast<unsigned long long>(call.answered()),
        call.answered()
            ? 100.0 * static_cast<double>(within_10) / static_cast<double>(call.answered())
            : 0.0,
        static_cast<unsigned long long>(call.refused()),
        static_cast<unsigned long long>(call.failed()),
        shapesense::bucketQuantile(bounds, counts, 0.5),
        shapesense::bucketQuantile(bounds, counts, 0.99));
  }
}

/// One query, chosen by `turn` (8 of 10 EstimateBox, then GetBowls, GetPlanes at the newest
/// processed frame: the newest frame itself is usually still in the detectors).
std::pair<std::string, grpc::Status> query(v1::ShapeSense::Stub& stub, grpc::ClientContext& context,
                                           unsigned turn, const Newest& newest) {
  context.set_deadline(deadlineAt(Clock::now() + std::chrono::seconds(10)));
  switch (turn % 10) {
    case 7: {
      v1::GetBowlsRequest request;
      request.set_at_ns(newest.timestamp_ns.load());
      v1::GetBowlsResponse response;
      return {"GetBowls", stub.GetBowls(&context, request, &response)};
    }
    case 8: {
      v1::GetPlanesRequest request;
      request.set_at_ns(newest.timestamp_ns.load());
      v1::GetPlanesResponse response;
      return {"GetPlanes", stub.GetPlanes(&context, request, &response)};
    }
    default: {
      v1::EstimateBoxRequest request;
      request.mutable_p1()->set_x(220 + static_cast<int>(turn % 7) * 10);
      request.mutable_p1()->set_y(160);
      request.mutable_p2()->set_x(420);
      request.mutable_p2()->set_y(340);
      request.set_mode(v1::BOX_MODE_AXIS_ALIGNED_CONTAINED);
      v1::EstimateBoxResponse response;
      return {"EstimateBox", stub.EstimateBox(&context, request, &response)};
    }
  }
}

/// A channel of its own, on its own connection, as a separate client process would have.
std::shared_ptr<grpc::Channel> ownChannel(const shapesense::cli::GlobalOptions& global,
                                          grpc::ChannelArguments args = {}) {
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return shapesense::cli::makeChannel(global, args);
}

/// How long the daemon asked a refused client to wait (gRPC's retry pushback), or `fallback_ms`
/// when it did not say.
int pushbackMs(const grpc::ClientContext& context, int fallback_ms) {
  const auto& trailers = context.GetServerTrailingMetadata();
  const auto found = trailers.find("grpc-retry-pushback-ms");
  if (found == trailers.end()) return fallback_ms;
  int ms = fallback_ms;
  const std::string_view text(found->second.data(), found->second.size());
  std::from_chars(text.data(), text.data() + text.size(), ms);
  return std::clamp(ms, 0, 60'000);
}

void runClient(const shapesense::cli::GlobalOptions& global, Clock::time_point end, unsigned seed,
               int backoff_ms, bool ignore_pushback, const Newest& newest, ClientStats& stats) {
  const auto stub = v1::ShapeSense::NewStub(ownChannel(global));
  std::optional<Clock::time_point> first_attempt;
  for (unsigned turn = seed; Clock::now() < end;) {
    grpc::ClientContext context;
    const auto start = Clock::now();
    if (!first_attempt) first_attempt = start;
    const auto [method, status] = query(*stub, context, turn, newest);
    const auto now = Clock::now();
    const std::chrono::duration<double, std::milli> took = now - start;
    if (status.ok()) {
      stats.latency_ms[method].push_back(took.count());
      stats.to_answer_ms.push_back(
          std::chrono::duration<double, std::milli>(now - *first_attempt).count());
      first_attempt.reset();
      ++turn;  // a refused query is asked again, not replaced by the next one
      continue;
    }
    if (status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) {
      first_attempt.reset();
      ++turn;
    }
    ++stats.errors[status.error_code()];
    stats.error_ms[shapesense::cli::statusCodeName(status.error_code())].push_back(took.count());
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      const int wait_ms = ignore_pushback ? backoff_ms : pushbackMs(context, backoff_ms);
      if (wait_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
    }
  }
}

/// Reads every summary, to know the newest processed frame.
void runTracker(const shapesense::cli::GlobalOptions& global, Clock::time_point end,
                Newest& newest) {
  const auto stub = v1::ShapeSense::NewStub(ownChannel(global));
  grpc::ClientContext context;
  context.set_deadline(deadlineAt(end));
  auto stream = stub->Watch(&context, v1::WatchRequest());
  v1::FrameSummary summary;
  while (stream->Read(&summary)) {
    if (!summary.info().processed()) continue;
    newest.timestamp_ns = summary.info().timestamp_ns();
    newest.sequence = summary.info().sequence();
  }
  stream->Finish();
}

void runSlowWatcher(const shapesense::cli::GlobalOptions& global, Clock::time_point end,
                    int read_ms, const Newest& newest, WatcherStats& stats) {
  const auto stub =
      v1::ShapeSense::NewStub(ownChannel(global, shapesense::cli::freshStreamArguments()));
  grpc::ClientContext context;
  context.set_deadline(deadlineAt(end));
  auto stream = stub->Watch(&context, v1::WatchRequest());
  v1::FrameSummary summary;
  while (stream->Read(&summary)) {
    ++stats.summaries;
    stats.dropped_before += summary.dropped_before();
    stats.with_drops += summary.dropped_before() > 0;
    const std::uint64_t newest_sequence = newest.sequence.load();
    if (newest_sequence > summary.info().sequence())
      stats.behind.push_back(static_cast<double>(newest_sequence - summary.info().sequence()));
    else
      stats.behind.push_back(0);
    if (Clock::now() >= end) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(read_ms));
  }
  context.TryCancel();
  const auto status = stream->Finish();
  stats.end = status.error_code();
}

double percentile(std::vector<double>& values, double q) {
  return values.empty() ? 0.0 : shapesense::quantile(values, q);
}

void report(std::vector<ClientStats>& clients, const std::vector<WatcherStats>& watchers,
            double seconds, std::uint64_t skipped, double rss_start, double rss_end) {
  std::map<std::string, std::vector<double>> latency;
  std::map<grpc::StatusCode, std::uint64_t> errors;
  std::map<std::string, std::vector<double>> error_ms;
  std::vector<double> to_answer;
  for (auto& c : clients) {
    to_answer.insert(to_answer.end(), c.to_answer_ms.begin(), c.to_answer_ms.end());
    for (auto& [method, values] : c.latency_ms)
      latency[method].insert(latency[method].end(), values.begin(), values.end());
    for (const auto& [code, n] : c.errors) errors[code] += n;
    for (auto& [code, values] : c.error_ms)
      error_ms[code].insert(error_ms[code].end(), values.begin(), values.end());
  }
  std::vector<double> all;
  for (const auto& [method, values] : latency) all.insert(all.end(), values.begin(), values.end());
  std::uint64_t failed = 0;
  for (const auto& [code, n] : errors) failed += n;
  std::printf("requests %zu ok, %llu failed in %.1f s: %.0f req/s\n", all.size(),
              static_cast<unsigned long long>(failed), seconds,
              static_cast<double>(all.size() + failed) / seconds);
  std::printf("latency ms   p50 %.2f  p99 %.2f  (all methods)\n", percentile(all, 0.5),
              percentile(all, 0.99));
  for (auto& [method, values] : latency)
    std::printf("  %-12s n %zu  p50 %.2f  p99 %.2f\n", method.c_str(), values.size(),
                percentile(values, 0.5), percentile(values, 0.99));
  std::printf("time to an answer, refusals and waits included: p50 %.2f  p99 %.2f ms\n",
              percentile(to_answer, 0.5), percentile(to_answer, 0.99));
  const auto exhausted = errors.find(grpc::StatusCode::RESOURCE_EXHAUSTED);
  const std::uint64_t refused = exhausted == errors.end() ? 0 : exhausted->second;
  std::printf("refused (RESOURCE_EXHAUSTED): %llu = %.1f%% of calls\n",
              static_cast<unsigned long long>(refused),
              100.0 * static_cast<double>(refused) / static_cast<double>(all.size() + failed));
  for (const auto& [code, n] : errors) {
    auto& took = error_ms[shapesense::cli::statusCodeName(code)];
    std::printf("errors: %s x %llu (answered in p50 %.2f, p99 %.2f ms)\n",
                shapesense::cli::statusCodeName(code).c_str(), static_cast<unsigned long long>(n),
                percentile(took, 0.5), percentile(took, 0.99));
  }
  std::uint64_t summaries = 0, dropped = 0, with_drops = 0;
  std::vector<double> behind;
  int ended_early = 0;
  for (const auto& w : watchers) {
    summaries += w.summaries;
    dropped += w.dropped_before;
    with_drops += w.with_drops;
    behind.insert(behind.end(), w.behind.begin(), w.behind.end());
    ended_early += w.end != grpc::StatusCode::OK && w.end != grpc::StatusCode::CANCELLED &&
                   w.end != grpc::StatusCode::DEADLINE_EXCEEDED;
  }
  std::printf(
      "slow watchers %zu: %llu summaries read, %llu of them with dropped_before > 0, "
      "dropped_before sum %llu, %d ended by error\n",
      watchers.size(), static_cast<unsigned long long>(summaries),
      static_cast<unsigned long long>(with_drops), static_cast<unsigned long long>(dropped),
      ended_early);
  if (!behind.empty()) {
    const double most = *std::max_element(behind.begin(), behind.end());
    std::printf("  frames behind the newest processed when read: p50 %.0f  p99 %.0f  max %.0f\n",
                percentile(behind, 0.5), percentile(behind, 0.99), most);
  }
  std::printf("daemon frames skipped during the run: %llu\n",
              static_cast<unsigned long long>(skipped));
  if (rss_start >= 0) std::printf("daemon RSS MiB: start %.1f, end %.1f\n", rss_start, rss_end);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"shapesense-load: load and soak test of a running shapesensed"};
  shapesense::cli::GlobalOptions global;
  shapesense::cli::addGlobalOptions(app, global);
  LoadOptions o;
  app.add_option("--clients", o.clients, "query clients")->check(CLI::Range(1, 1024));
  app.add_option("--slow-watchers", o.slow_watchers, "slow Watch subscribers")
      ->check(CLI::Range(0, 1024));
  app.add_option("--seconds", o.seconds, "duration")->check(CLI::Range(1.0, 86400.0));
  app.add_option("--slow-read-ms", o.slow_read_ms, "pause of a slow subscriber per summary")
      ->check(CLI::Range(1, 60000));
  app.add_option("--daemon-pid", o.daemon_pid, "the daemon's pid, for its resident memory");
  app.add_option("--backoff-ms", o.backoff_ms,
                 "pause of a client after a RESOURCE_EXHAUSTED answer without the daemon's retry "
                 "pushback (0 = retry at once)")
      ->check(CLI::Range(0, 60000))
      ->capture_default_str();
  app.add_flag("--ignore-pushback", o.ignore_pushback,
               "pause --backoff-ms after a refusal even when the daemon says how long to wait, "
               "as clients that do not read gRPC's retry pushback do");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto channel = shapesense::cli::makeChannel(global);
    const auto stub = v1::ShapeSense::NewStub(channel);
    const v1::GetStatusResponse status_start = daemonStatus(*stub);
    const double rss_start = residentMiB(o.daemon_pid);
    const auto start = Clock::now();
    const auto end = start + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(o.seconds));
    std::vector<ClientStats> clients(static_cast<std::size_t>(o.clients));
    std::vector<WatcherStats> watchers(static_cast<std::size_t>(o.slow_watchers));
    std::vector<std::thread> threads;
    Newest newest;
    threads.emplace_back(runTracker, std::cref(global), end, std::ref(newest));
    for (std::size_t i = 0; i < watchers.size(); ++i)
      threads.emplace_back(runSlowWatcher, std::cref(global), end, o.slow_read_ms,
                           std::cref(newest), std::ref(watchers[i]));
    for (std::size_t i = 0; i < clients.size(); ++i)
      threads.emplace_back(runClient, std::cref(global), end, static_cast<unsigned>(i),
                           o.backoff_ms, o.ignore_pushback, std::cref(newest),
                           std::ref(clients[i]));
    for (auto& t : threads) t.join();
    const std::chrono::duration<double> took = Clock::now() - start;
    const v1::GetStatusResponse status_end = daemonStatus(*stub);
    report(clients, watchers, took.count(),
           status_end.frames_skipped() - status_start.frames_skipped(), rss_start,
           residentMiB(o.daemon_pid));
    reportDaemonSide(callsDuringRun(status_start, status_end));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shapesense-load: %s\n", e.what());
    return 1;
  }
  return 0;
}
