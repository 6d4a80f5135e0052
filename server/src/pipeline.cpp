#include "shapesense/server/pipeline.h"

#include <spdlog/spdlog.h>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/server/thread_priority.h"

namespace shapesense {

const char* toString(SourceState state) {
  switch (state) {
    case SourceState::kStreaming:
      return "streaming";
    case SourceState::kEnded:
      return "ended";
    case SourceState::kFailed:
      return "failed";
    case SourceState::kStopped:
      return "stopped";
    case SourceState::kReconnecting:
      return "reconnecting";
  }
  return "unknown";
}

Pipeline::Pipeline(std::unique_ptr<FrameSource> source, DetectorChain chain, FrameCache& cache,
                   SummaryHub& hub, FrameTap* tap, PipelineOptions options)
    : source_(std::move(source)),
      source_name_(source_->describe()),
      chain_(std::move(chain)),
      cache_(cache),
      hub_(hub),
      tap_(tap),
      options_(options) {}

Pipeline::~Pipeline() { stop(); }

void Pipeline::start() {
  {
    std::lock_guard lock(mutex_);
    last_source_event_ = std::chrono::steady_clock::now();
  }
  capture_thread_ = std::jthread([this](std::stop_token stop) { captureLoop(stop); });
  detect_thread_ = std::jthread([this](std::stop_token stop) { detectLoop(stop); });
}

void Pipeline::stop() {
  capture_thread_.request_stop();
  detect_thread_.request_stop();
  if (capture_thread_.joinable()) capture_thread_.join();
  if (detect_thread_.joinable()) detect_thread_.join();
}

void Pipeline::prepareThisThread(const char* name) {
  nameThisThread(name);
  if (options_.thread_nice == 0 || setThisThreadNice(options_.thread_nice)) return;
  std::call_once(priority_refused_, [&] {
    spdlog::warn(
        "the system refused nice {} for the capture and detector threads (it needs root, "
        "CAP_SYS_NICE or LimitNICE=); they run at nice {}, and a busy machine may make them "
        "skip frames",
        options_.thread_nice, thisThreadNice());
  });
}

void Pipeline::setState(SourceState state, std::string message) {
  std::lock_guard lock(mutex_);
  state_ = state;
  if (!message.empty()) last_error_ = std::move(message);
}

void Pipeline::captureLoop(std::stop_token stop) {
  prepareThisThread("ss-capture");
  while (!stop.stop_requested()) {
    SourceEvent event;
    try {
      event = source_->next(stop);
      noteSourceEvent();
    } catch (const std::exception& e) {
      spdlog::error("source {} failed: {}", source_name_, e.what());
      setState(SourceState::kFailed, e.what());
      break;
    }
    if (auto* error = std::get_if<SourceError>(&event)) {
      ++source_errors_;
      spdlog::warn("{}", error->message);
      std::lock_guard lock(mutex_);
      last_error_ = error->message;
      continue;
    }
    if (std::holds_alternative<EndOfStream>(event)) {
      if (stop.stop_requested()) break;
      spdlog::info("source {} ended; serving the {} cached frames", source_name_,
                   cache_.range().frames);
      setState(SourceState::kEnded);
      break;
    }
    auto frame = std::make_shared<const Frame>(std::move(std::get<Frame>(event)));
    if (!cache_.insert(frame)) {
      ++out_of_order_;
      std::string message = "frame " + std::to_string(frame->sequence) + " stamped " +
                            formatNsAsSeconds(frame->timestamp_ns) +
                            " s is not after the newest cached frame (" +
                            formatNsAsSeconds(cache_.range().newest_ns) + " s); dropped";
      // A clock that went back refuses every frame until it passes the newest again: one line
      // when that starts and one when it ends, not one per frame.
      if (out_of_order_run_++ == 0) spdlog::warn("{}", message);
      std::lock_guard lock(mutex_);
      last_error_ = std::move(message);
      continue;
    }
    if (out_of_order_run_ > 0) {
      spdlog::info("{}: stamps increase again; {} frame(s) were dropped out of order", source_name_,
                   out_of_order_run_);
      out_of_order_run_ = 0;
    }
    ++received_;
    if (tap_) tap_->publish(frame);
    {
      std::lock_guard lock(mutex_);
      if (waiting_) ++skipped_;
      waiting_ = std::move(frame);
    }
    changed_.notify_all();
  }
  {
    std::lock_guard lock(mutex_);
    capture_done_ = true;
    if (stop.stop_requested() && state_ == SourceState::kStreaming) state_ = SourceState::kStopped;
  }
  changed_.notify_all();
}

void Pipeline::detectLoop(std::stop_token stop) {
  prepareThisThread("ss-detect");
  while (true) {
    std::shared_ptr<const Frame> frame;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, stop, [this] { return waiting_ != nullptr || capture_done_; });
      if (stop.stop_requested() || !waiting_) break;
      frame = std::move(waiting_);
      waiting_.reset();
      detecting_ = true;
      detecting_since_ = std::chrono::steady_clock::now();
    }
    const auto start = std::chrono::steady_clock::now();
    auto results = std::make_shared<const FrameResults>(chain_.process(*frame));
    const std::chrono::duration<double, std::milli> total =
        std::chrono::steady_clock::now() - start;
    for (const auto& [stage, ms] : results->timings_ms) latency_.record(stage, ms);
    latency_.record("total", total.count());
    if (!results->stage_errors.empty()) logStageErrors(*results);
    cache_.publishResults(frame->sequence, results);
    hub_.publish(CachedFrame{frame, results});
    ++processed_;
    {
      std::lock_guard lock(mutex_);
      detecting_ = false;
    }
    changed_.notify_all();
  }
  {
    std::lock_guard lock(mutex_);
    detecting_ = false;
  }
  changed_.notify_all();
}

void Pipeline::logStageErrors(const FrameResults& results) {
  const auto now = std::chrono::steady_clock::now();
  for (const auto& [stage, message] : results.stage_errors) {
    auto [entry, first] = stage_error_log_.try_emplace(stage);
    StageErrorLog& log = entry->second;
    ++log.since_logged;
    if (!first && now - log.logged < std::chrono::minutes(1)) continue;
    spdlog::error("detector stage {} failed on a frame ({} failures since the last report): {}",
                  stage, log.since_logged, message);
    log.logged = now;
    log.since_logged = 0;
  }
}

bool Pipeline::waitUntilDrained(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout,
                           [this] { return capture_done_ && !waiting_ && !detecting_; });
}

void Pipeline::noteSourceEvent() {
  std::lock_guard lock(mutex_);
  last_source_event_ = std::chrono::steady_clock::now();
}

SourceState Pipeline::reportedState(SourceState state) const {
  if (state != SourceState::kStreaming) return state;
  const SourceHealth health = source_->health();
  return health.live && !health.connected ? SourceState::kReconnecting : state;
}

PipelineProgress Pipeline::progress() const {
  PipelineProgress p;
  p.source = source_name_;
  SourceState state;
  {
    std::lock_guard lock(mutex_);
    state = state_;
    p.last_source_event = last_source_event_;
    if (detecting_) p.detecting_since = detecting_since_;
  }
  p.state = reportedState(state);
  return p;
}

PipelineStatus Pipeline::status() const {
  PipelineStatus s;
  s.source = source_name_;
  {
    std::lock_guard lock(mutex_);
    s.state = state_;
    s.last_error = last_error_;
  }
  s.frames_received = received_;
  s.frames_processed = processed_;
  s.frames_skipped = skipped_;
  s.source_errors = source_errors_;
  s.frames_out_of_order = out_of_order_;
  s.stages = latency_.summaries();
  s.detectors = chain_.stageNames();
  s.health = source_->health();
  s.state = reportedState(s.state);
  return s;
}

}  // namespace shapesense
