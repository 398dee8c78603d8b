#include <cstdlib>

#include <gtest/gtest.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "tescalib/core/common/allocator.h"

namespace tescalib {

#if defined(__GLIBC__)
/// Blocks held by mmap while `bytes` are allocated, after one such block was freed.
int mmappedBlocksOfASecondAllocation(size_t bytes) {
  // volatile: the compiler may not drop a malloc and free pair whose block goes unused
  void* volatile first = std::malloc(bytes);
  std::free(first);  // glibc's dynamic threshold rises to this size here
  void* volatile second = std::malloc(bytes);
  const int blocks = mallinfo2().hblks;
  std::free(second);
  return blocks;
}

TEST(Allocator, LargeBlocksStayMappedAfterOneWasFreed) {
  const int base = mallinfo2().hblks;
  // By default the second block comes from the heap, which keeps it.
  EXPECT_EQ(mmappedBlocksOfASecondAllocation(4 << 20), base);
  ASSERT_TRUE(keepResidentMemoryFlat());
  // Larger than what the heap holds free after the first: mapped, and returned when freed.
  EXPECT_EQ(mmappedBlocksOfASecondAllocation(16 << 20), base + 1);
}
#endif

}  // namespace tescalib
