#pragma once
// How the daemon's process keeps memory between frames. Every frame, the detectors allocate
// and free frame-sized buffers (clouds, normal images, sort buffers: tens of MB). By default
// glibc gives blocks that large back to the kernel when they are freed, so the next frame
// faults every page in again and the kernel clears it: the recognition's surface cloud of a
// VGA frame took 17 ms under glibc's defaults and 9.5 ms under this policy (docs/benchmarks.md).
// Keeping them in the heap makes the process's resident size its peak, which a daemon reaches
// within the first frames anyway.

namespace shapesense {

/// Asks glibc to serve blocks up to 32 MB from the heap and to keep up to 512 MB of freed heap
/// instead of returning it to the kernel. Call once, at the start of a program that processes
/// frames (the daemon, the benchmarks). False when glibc refused a setting.
bool keepFrameBuffersAllocated();

}  // namespace shapesense
