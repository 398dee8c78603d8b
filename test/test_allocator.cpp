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

TEST(Allocator, MidSizedBlocksComeFromTheHeapAndHugeOnesAreMapped) {
  ASSERT_TRUE(keepResidentMemoryFlat());
  const int base = mallinfo2().hblks;
  // An image-sized block is used again from the heap (no page faults when it is touched again).
  EXPECT_EQ(mmappedBlocksOfASecondAllocation(1 << 20), base);
  EXPECT_EQ(mmappedBlocksOfASecondAllocation(kMmapThresholdBytes / 2), base);
  // Beyond the fixed threshold: mapped, and returned when freed, however often one was freed.
  EXPECT_EQ(mmappedBlocksOfASecondAllocation(kMmapThresholdBytes + (4 << 20)), base + 1);
  EXPECT_EQ(mallinfo2().hblks, base);
}

TEST(Allocator, FreeMemoryGoesBackEveryTwentiethKeyframe) {
  for (int k : {1, kKeyframesPerTrim - 1, kKeyframesPerTrim + 1})
    EXPECT_FALSE(returnFreeMemoryAfterKeyframe(k)) << k;
  for (int k : {kKeyframesPerTrim, 2 * kKeyframesPerTrim})
    EXPECT_TRUE(returnFreeMemoryAfterKeyframe(k)) << k;
}
#endif

}  // namespace tescalib
