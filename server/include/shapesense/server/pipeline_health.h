#pragma once
// Whether the pipeline is alive, for the systemd watchdog: the daemon pets the watchdog only
// while it is, so a capture or detector thread that hangs gets the daemon restarted. Idle is
// alive: a recording that ended, a source that failed or stopped, and a sensor being
// reconnected all leave the pipeline waiting on purpose.

#include <chrono>
#include <optional>
#include <string>

#include "shapesense/server/pipeline.h"

namespace shapesense {

struct HealthVerdict {
  bool healthy = true;
  std::string reason;  ///< why not, for the log
};

/// Judges `progress` at `now`: unhealthy when a streaming source has delivered nothing (no
/// frame, no error) for longer than `stall_limit`, or the detectors have spent longer than
/// that on one frame.
HealthVerdict judgePipelineHealth(const PipelineProgress& progress,
                                  std::chrono::steady_clock::time_point now,
                                  std::chrono::steady_clock::duration stall_limit);

}  // namespace shapesense
