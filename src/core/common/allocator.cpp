#include "tescalib/core/common/allocator.h"

#include <cstdlib>  // defines __GLIBC__ where it applies

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace tescalib {

bool keepResidentMemoryFlat() {
#if defined(__GLIBC__)
  const bool threshold = mallopt(M_MMAP_THRESHOLD, 256 * 1024) == 1;
  const bool arenas = mallopt(M_ARENA_MAX, 2) == 1;
  return threshold && arenas;
#else
  return false;
#endif
}

}  // namespace tescalib
