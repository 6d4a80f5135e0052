// The daemon's memory policy: a freed frame-sized buffer stays in the process for the next
// frame instead of going back to the kernel. Under glibc's defaults, in a process of its own
// (as ctest runs each test), a block this large is mapped on its own and unmapped when freed.

#include "shapesense/server/frame_memory.h"

#include <malloc.h>

#include <cstddef>
#include <cstdlib>
#include <cstring>

#include <gtest/gtest.h>

namespace shapesense {
namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitizerAllocator = true;
#else
constexpr bool kSanitizerAllocator = false;
#endif

TEST(FrameMemory, AFreedFrameBufferStaysInTheProcess) {
  if (kSanitizerAllocator) GTEST_SKIP() << "the sanitizer's allocator replaces glibc's";
  ASSERT_TRUE(keepFrameBuffersAllocated());
  constexpr std::size_t kFrameBuffer = 16u << 20;  // a VGA cloud with normals is about this
  const std::size_t mapped_before = mallinfo2().hblkhd;
  void* volatile buffer = std::malloc(kFrameBuffer);
  ASSERT_NE(buffer, nullptr);
  std::memset(buffer, 1, kFrameBuffer);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before) << "the buffer was mapped on its own";
  std::free(buffer);
  // It may have come from free heap that earlier tests of this process left; either way the
  // heap now holds at least its size free.
  EXPECT_GE(mallinfo2().fordblks, kFrameBuffer) << "the freed buffer went back to the kernel";
}

}  // namespace
}  // namespace shapesense
