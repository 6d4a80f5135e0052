// `shapesense record`: a recording in the TUM layout with camera.json, which replays
// bit-identically with --source tum:DIR. With --source the CLI opens the source itself (no
// daemon); without it the daemon records what its source delivers (Record RPC), on its machine.

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>

#include "commands.h"
#include "shapesense/driver/open_source.h"
#include "shapesense/driver/tum_recording.h"

namespace shapesense::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void printProgress(const std::string& dir, std::uint64_t frames, double seconds,
                   std::uint64_t dropped, bool done) {
  std::fprintf(stderr, "\rrecording %s: %llu frame(s), %.1f s", dir.c_str(),
               static_cast<unsigned long long>(frames), seconds);
  if (dropped > 0) std::fprintf(stderr, ", %llu dropped", static_cast<unsigned long long>(dropped));
  std::fprintf(stderr, done ? "\n" : "   ");
  std::fflush(stderr);
}

void requireEmptyOrMissing(const fs::path& dir) {
  if (!fs::exists(dir)) return;
  if (!fs::is_directory(dir))
    throw std::runtime_error("'" + dir.string() + "' exists and is not a directory");
  if (!fs::is_empty(dir)) {
    throw std::runtime_error("'" + dir.string() +
                             "' is not empty: choose a new directory (or empty this one)");
  }
}

/// Opens the source here and writes its frames; seconds = 0: until the source ends.
void recordFromSource(const std::string& spec, Pacing pacing, const fs::path& dir, double seconds) {
  requireEmptyOrMissing(dir);
  auto source = openSource(spec, pacing, /*loop=*/false);
  std::stop_source stop;
  std::optional<std::jthread> timer;
  if (seconds > 0) {
    // Stops a next() that waits for a sensor when the time is up.
    timer.emplace([&stop, seconds](std::stop_token cancelled) {
      std::mutex m;
      std::condition_variable_any cv;
      std::unique_lock lock(m);
      cv.wait_for(lock, cancelled, std::chrono::duration<double>(seconds), [] { return false; });
      stop.request_stop();
    });
  }
  const auto start = Clock::now();
  std::optional<TumRecordingWriter> out;
  std::uint64_t written = 0, errors = 0;
  auto last_print = start;
  const auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  while (!stop.stop_requested()) {
    SourceEvent event = source->next(stop.get_token());
    if (std::holds_alternative<EndOfStream>(event)) break;
    if (auto* error = std::get_if<SourceError>(&event)) {
      ++errors;
      std::fprintf(stderr, "\n%s\n", error->message.c_str());
      continue;
    }
    if (seconds > 0 && elapsed() >= seconds) break;
    const Frame& frame = std::get<Frame>(event);
    if (!out) {
      RecordingCamera camera;
      camera.intrinsics = frame.intrinsics;
      out.emplace(dir, camera);
    }
    out->write(frame);
    ++written;
    if (Clock::now() - last_print >= std::chrono::milliseconds(100)) {
      printProgress(dir.string(), written, elapsed(), 0, false);
      last_print = Clock::now();
    }
  }
  if (timer) timer->request_stop();
  printProgress(dir.string(), written, elapsed(), 0, true);
  if (written == 0)
    throw std::runtime_error(source->describe() + " delivered no frame; nothing was recorded");
  std::cout << written << " frame(s) from " << source->describe() << " written to " << dir.string();
  if (errors > 0) std::cout << " (" << errors << " source error(s))";
  std::cout << "\n";
}

void recordOnDaemon(const GlobalOptions& global, const std::string& name, double seconds) {
  Connection connection(global);
  auto context = Connection::streamContext();
  // The stream runs `seconds` plus the time to write what is queued; allow generous slack.
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(
                            std::chrono::duration<double>(seconds + global.timeout_s + 30.0)));
  v1::RecordRequest request;
  request.set_dir(name);
  request.set_seconds(seconds);
  auto reader = connection.stub().Record(context.get(), request);
  v1::RecordProgress progress;
  std::optional<v1::RecordProgress> last;
  while (reader->Read(&progress)) {
    printProgress(progress.dir(), progress.frames_written(), progress.seconds(),
                  progress.frames_dropped(), progress.done());
    last = progress;
  }
  const grpc::Status status = reader->Finish();
  if (!status.ok() && last && !last->done()) std::fputc('\n', stderr);
  Connection::check(status);
  if (!last || !last->done())
    throw std::runtime_error("the daemon ended the recording without a final report");
  if (last->frames_written() == 0) {
    throw std::runtime_error("the daemon's source delivered no frame in " +
                             std::to_string(seconds) +
                             " s; nothing was recorded (see `shapesense status`)");
  }
  std::cout << last->frames_written() << " frame(s) written by the daemon to " << last->dir();
  if (last->frames_dropped() > 0)
    std::cout << " (" << last->frames_dropped() << " dropped: disk too slow)";
  std::cout << "\n";
}

}  // namespace

void addRecordCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand(
      "record",
      "Record frames in the TUM layout with camera.json (replay with shapesensed --source "
      "tum:DIR). "
      "With --source the CLI reads the source itself; without, the daemon records on its machine");
  struct Args {
    std::string out;
    double seconds = 10;
    std::string source;
    std::string rate = "max";
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--out", args->out,
                  "Output directory, new or empty. Without --source: a name under the daemon's "
                  "recordings root (shapesensed --record-root), e.g. desk-1")
      ->required();
  cmd->add_option("--seconds", args->seconds,
                  "Wall-clock duration; with --source, 0 = until the source ends")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  cmd->add_option("--source", args->source,
                  std::string("Record this source without a daemon: ") + kSourceSpecs);
  cmd->add_option("--rate", args->rate,
                  "With --source, for recorded sources: recorded (real time) or max")
      ->check(CLI::IsMember({"recorded", "max"}))
      ->capture_default_str();
  cmd->callback([&global, args] {
    if (!args->source.empty()) {
      recordFromSource(args->source,
                       args->rate == "max" ? Pacing::kAsFastAsPossible : Pacing::kRecorded,
                       args->out, args->seconds);
      return;
    }
    if (args->seconds <= 0)
      throw CLI::ValidationError("--seconds", "must be more than 0 when the daemon records");
    recordOnDaemon(global, args->out, args->seconds);
  });
}

}  // namespace shapesense::cli
