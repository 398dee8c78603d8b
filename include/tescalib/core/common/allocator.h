// The allocator's settings for a calibrator that runs for hours. Every keyframe allocates and frees
// images, disparity maps, clouds and meshes of 0.3-10 MB on several threads. By default glibc
// gives each thread an arena of its own (up to 8 per core), which keeps what is freed: the
// resident memory of a 10-minute drive grows by 100-170 MB while the heap in use stays flat. At
// most two arenas keep it flat. Blocks up to 32 MiB come from the arenas, and up to 32 MiB free at
// an arena's top stay there, so that a freed block is used again as it is: a block mapped from (or
// returned to) the system at each allocation costs a page fault per 4 KiB touched, a third of a
// keyframe's time on a virtual machine (doc/online.md, Memory).
#pragma once

#include <cstddef>

namespace tescalib {

/// Blocks of at least this size are mapped from the system and returned to it when freed; free
/// memory beyond it at an arena's top is returned too.
constexpr size_t kMmapThresholdBytes = size_t{32} << 20;

/// Sets the process's allocator to use at most two arenas, with fixed mmap and trim thresholds of
/// kMmapThresholdBytes (glibc's largest dynamic mmap threshold). Process-wide; call before the
/// threads start. Returns false where the C library has no such settings (not glibc).
bool keepResidentMemoryFlat();

/// Returns the arenas' free pages to the system (glibc's malloc_trim), wherever they are in the
/// heap: what the arenas' fragmentation would otherwise keep resident. The pages come back with a
/// page fault each when used again. False where the C library has no such call.
bool returnFreeMemory();
/// What a long-running calibrator calls after each new keyframe, `keyframes` counting them:
/// returnFreeMemory() every kKeyframesPerTrim keyframes. True when it trimmed.
bool returnFreeMemoryAfterKeyframe(int keyframes);
constexpr int kKeyframesPerTrim = 20;

}  // namespace tescalib
