// The main of every benchmark without one of its own: the daemon's memory policy
// (frame_memory.h), so that the figures are those the daemon sees, then Google Benchmark's.

#include <benchmark/benchmark.h>

#include "shapesense/server/frame_memory.h"

int main(int argc, char** argv) {
  shapesense::keepFrameBuffersAllocated();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
