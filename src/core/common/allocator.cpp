#include "tescalib/core/common/allocator.h"

#include <cstdlib>  // defines __GLIBC__ where it applies

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace tescalib {

bool keepResidentMemoryFlat() {
#if defined(__GLIBC__)
  const int bytes = static_cast<int>(kMmapThresholdBytes);
  const bool threshold = mallopt(M_MMAP_THRESHOLD, bytes) == 1;
  const bool trim = mallopt(M_TRIM_THRESHOLD, bytes) == 1;
  const bool arenas = mallopt(M_ARENA_MAX, 2) == 1;
  return threshold && trim && arenas;
#else
  return false;
#endif
}

bool returnFreeMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
  return true;
#else
  return false;
#endif
}

bool returnFreeMemoryAfterKeyframe(int keyframes) {
  return keyframes % kKeyframesPerTrim == 0 && returnFreeMemory();
}

}  // namespace tescalib
