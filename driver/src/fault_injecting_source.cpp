#include "shapesense/driver/fault_injecting_source.h"

#include <string>
#include <utility>

namespace shapesense {

FaultPlan& FaultPlan::pass(std::size_t events) {
  steps_.push_back({.kind = FaultStep::Kind::kPass, .count = events});
  return *this;
}

FaultPlan& FaultPlan::error(std::size_t count) {
  steps_.push_back({.kind = FaultStep::Kind::kError, .count = count});
  return *this;
}

FaultPlan& FaultPlan::stall(std::chrono::milliseconds duration) {
  steps_.push_back({.kind = FaultStep::Kind::kStall, .duration = duration});
  return *this;
}

FaultPlan& FaultPlan::disconnect(std::chrono::milliseconds duration) {
  steps_.push_back({.kind = FaultStep::Kind::kDisconnect, .duration = duration});
  return *this;
}

FaultPlan& FaultPlan::stampBack(TimestampNs offset_ns) {
  steps_.push_back({.kind = FaultStep::Kind::kStampBack, .offset_ns = offset_ns});
  return *this;
}

FaultPlan& FaultPlan::stampRepeat() {
  steps_.push_back({.kind = FaultStep::Kind::kStampRepeat});
  return *this;
}

FaultInjectingSource::FaultInjectingSource(std::unique_ptr<FrameSource> inner, FaultPlan plan)
    : inner_(std::move(inner)), steps_(plan.steps()) {
  for (const auto& step : steps_) has_disconnect_ |= step.kind == FaultStep::Kind::kDisconnect;
}

std::string FaultInjectingSource::describe() const { return "faults(" + inner_->describe() + ")"; }

SourceHealth FaultInjectingSource::health() const {
  SourceHealth health = inner_->health();
  std::lock_guard lock(mutex_);
  health.live = health.live || has_disconnect_;
  health.connected = health.connected && connected_;
  health.disconnects += disconnects_;
  health.reconnects += reconnects_;
  return health;
}

void FaultInjectingSource::resume() {
  {
    std::lock_guard lock(mutex_);
    resume_pending_ = true;
  }
  resumed_.notify_all();
}

bool FaultInjectingSource::blocked() const {
  std::lock_guard lock(mutex_);
  return blocked_;
}

bool FaultInjectingSource::hold(std::chrono::milliseconds duration, const std::stop_token& stop) {
  std::unique_lock lock(mutex_);
  blocked_ = true;
  const auto resumed = [this] { return resume_pending_; };
  if (duration == kUntilResumed) {
    resumed_.wait(lock, stop, resumed);
  } else {
    resumed_.wait_for(lock, stop, duration, resumed);
  }
  // A resume() meant for this hold is used up by it, whether it or the timeout ended it.
  resume_pending_ = false;
  blocked_ = false;
  return !stop.stop_requested();
}

SourceEvent FaultInjectingSource::forward(std::stop_token stop) {
  SourceEvent event = inner_->next(stop);
  if (const auto* frame = std::get_if<Frame>(&event)) {
    last_stamp_ = frame->timestamp_ns;
    delivered_ = true;
  }
  return event;
}

SourceEvent FaultInjectingSource::next(std::stop_token stop) {
  while (step_ < steps_.size()) {
    const FaultStep& step = steps_[step_];
    const auto finish = [this] {
      ++step_;
      done_in_step_ = 0;
    };
    switch (step.kind) {
      case FaultStep::Kind::kPass:
        if (done_in_step_ < step.count) {
          ++done_in_step_;
          return forward(stop);
        }
        finish();
        break;
      case FaultStep::Kind::kError:
        if (done_in_step_ < step.count) {
          ++done_in_step_;
          return SourceError{describe() + ": injected error " + std::to_string(done_in_step_) +
                             " of " + std::to_string(step.count)};
        }
        finish();
        break;
      case FaultStep::Kind::kStall:
        finish();
        if (!hold(step.duration, stop)) return EndOfStream{};
        break;
      case FaultStep::Kind::kDisconnect:
        if (done_in_step_ == 0) {
          // Reported first, as a live source does, so the pipeline shows the loss at once.
          ++done_in_step_;
          {
            std::lock_guard lock(mutex_);
            connected_ = false;
            ++disconnects_;
          }
          return SourceError{describe() + ": sensor lost (injected); waiting for it"};
        }
        finish();
        if (!hold(step.duration, stop)) return EndOfStream{};
        {
          std::lock_guard lock(mutex_);
          connected_ = true;
          ++reconnects_;
        }
        break;
      case FaultStep::Kind::kStampBack:
      case FaultStep::Kind::kStampRepeat: {
        const TimestampNs previous = last_stamp_;
        const bool had_previous = delivered_;
        finish();
        SourceEvent event = forward(stop);
        if (auto* frame = std::get_if<Frame>(&event); frame && had_previous) {
          frame->timestamp_ns =
              step.kind == FaultStep::Kind::kStampRepeat ? previous : previous - step.offset_ns;
          last_stamp_ = frame->timestamp_ns;
        }
        return event;
      }
    }
  }
  return forward(stop);
}

}  // namespace shapesense
