#include "shapesense/server/pipeline_health.h"

#include <cstdio>

namespace shapesense {
namespace {

std::string seconds(std::chrono::steady_clock::duration d) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f s", std::chrono::duration<double>(d).count());
  return text;
}

}  // namespace

HealthVerdict judgePipelineHealth(const PipelineProgress& progress,
                                  std::chrono::steady_clock::time_point now,
                                  std::chrono::steady_clock::duration stall_limit) {
  if (progress.state == SourceState::kStreaming && now - progress.last_source_event > stall_limit) {
    return {false, "the source " + progress.source + " has delivered nothing for " +
                       seconds(now - progress.last_source_event)};
  }
  if (progress.detecting_since && now - *progress.detecting_since > stall_limit) {
    return {false, "the detectors have spent " + seconds(now - *progress.detecting_since) +
                       " on one frame"};
  }
  return {};
}

}  // namespace shapesense
