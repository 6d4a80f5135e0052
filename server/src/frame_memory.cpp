#include "shapesense/server/frame_memory.h"

#include <malloc.h>

namespace shapesense {

bool keepFrameBuffersAllocated() {
  // 32 MB is glibc's largest mmap threshold on 64-bit systems; larger blocks (a hostile image's
  // decode, bounded elsewhere) still come from and go back to the kernel.
  constexpr int kHeapBlocksUpTo = 32 << 20;
  constexpr int kFreeHeapKept = 512 << 20;
  const bool mmap_set = mallopt(M_MMAP_THRESHOLD, kHeapBlocksUpTo) == 1;
  const bool trim_set = mallopt(M_TRIM_THRESHOLD, kFreeHeapKept) == 1;
  return mmap_set && trim_set;
}

}  // namespace shapesense
