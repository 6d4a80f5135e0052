// The daemon's memory policy: a freed frame-sized buffer stays in the process for the next
// frame instead of going back to the kernel (each test runs in a process of its own, so glibc
// starts from its defaults, under which a block this large is mapped and unmapped).

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
  const std::size_t free_before = mallinfo2().fordblks;
  const std::size_t mapped_before = mallinfo2().hblkhd;
  void* volatile buffer = std::malloc(kFrameBuffer);
  ASSERT_NE(buffer, nullptr);
  std::memset(buffer, 1, kFrameBuffer);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before) << "the buffer was mapped on its own";
  std::free(buffer);
  EXPECT_GE(mallinfo2().fordblks, free_before + kFrameBuffer)
      << "the freed buffer went back to the kernel";
}

}  // namespace
}  // namespace shapesense
