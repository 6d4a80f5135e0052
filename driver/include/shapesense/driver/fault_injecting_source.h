#pragma once
// A FrameSource for tests that wraps another one and misbehaves on a script: errors, stalls, a
// sensor that is lost and comes back, stamps that jump back or repeat. It lets tests show what
// the pipeline and cache do with a faulty sensor without owning one.
//
// The plan is a list of steps played in order, each on the next call(s) of next(); once it is
// played the wrapped source's events pass through unchanged. Frames keep the wrapped source's
// sequence numbers; only their stamps are altered by the stamp steps.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "shapesense/driver/frame_source.h"

namespace shapesense {

/// One scripted fault. Build plans with FaultPlan.
struct FaultStep {
  enum class Kind {
    kPass,         ///< deliver `count` events of the wrapped source unchanged
    kError,        ///< report `count` SourceErrors ("injected error k of n")
    kStall,        ///< block in next() for `duration` (or until resume()), then go on
    kDisconnect,   ///< the sensor is lost: one SourceError, health() not connected, next()
                   ///< blocks for `duration` (or until resume()); then it is back (a reconnect)
    kStampBack,    ///< the next frame is stamped `offset_ns` before the last delivered stamp
    kStampRepeat,  ///< the next frame carries the last delivered stamp again
  };
  Kind kind = Kind::kPass;
  std::size_t count = 1;
  std::chrono::milliseconds duration{0};
  TimestampNs offset_ns = 0;
};

/// Blocks of kStall / kDisconnect with this duration last until FaultInjectingSource::resume().
inline constexpr std::chrono::milliseconds kUntilResumed = std::chrono::milliseconds::max();

/// A list of faults, written as a chain: FaultPlan().pass(5).disconnect(kUntilResumed).pass(3).
class FaultPlan {
 public:
  FaultPlan& pass(std::size_t events);
  FaultPlan& error(std::size_t count = 1);
  FaultPlan& stall(std::chrono::milliseconds duration);
  FaultPlan& disconnect(std::chrono::milliseconds duration);
  FaultPlan& stampBack(TimestampNs offset_ns);
  FaultPlan& stampRepeat();

  const std::vector<FaultStep>& steps() const { return steps_; }

 private:
  std::vector<FaultStep> steps_;
};

class FaultInjectingSource final : public FrameSource {
 public:
  FaultInjectingSource(std::unique_ptr<FrameSource> inner, FaultPlan plan);

  /// "faults(<wrapped source>)".
  std::string describe() const override;
  SourceEvent next(std::stop_token stop) override;
  /// The wrapped source's health, live once the plan has a disconnect, with the injected
  /// disconnections and reconnections added.
  SourceHealth health() const override;

  /// Ends the current kUntilResumed stall or disconnection (or the next one, if none is
  /// blocking yet). Any thread.
  void resume();
  /// Whether next() is blocked in a stall or disconnection now. Any thread.
  bool blocked() const;

 private:
  /// Blocks until `duration` passed, resume() or stop; false when stopped.
  bool hold(std::chrono::milliseconds duration, const std::stop_token& stop);
  SourceEvent forward(std::stop_token stop);

  std::unique_ptr<FrameSource> inner_;
  std::vector<FaultStep> steps_;
  bool has_disconnect_ = false;

  // next() only.
  std::size_t step_ = 0;
  std::size_t done_in_step_ = 0;
  TimestampNs last_stamp_ = 0;
  bool delivered_ = false;

  mutable std::mutex mutex_;
  std::condition_variable_any resumed_;
  bool resume_pending_ = false;
  bool blocked_ = false;
  bool connected_ = true;
  std::uint64_t disconnects_ = 0;
  std::uint64_t reconnects_ = 0;
};

}  // namespace shapesense
