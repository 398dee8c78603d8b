// The allocator's settings for a calibrator that runs for hours. Every keyframe allocates and frees
// images, disparity maps, clouds and meshes of 0.3-10 MB on several threads. glibc serves such
// blocks by mmap until it frees one, then raises its mmap threshold to that block's size (up to
// 32 MB) and serves later ones from per-thread arenas, which keep what is freed: the resident
// memory of a 10-minute drive grows by 100-170 MB while the heap in use stays flat. A fixed
// threshold and at most two arenas keep the resident memory flat (doc/online.md, Memory).
#pragma once

namespace tescalib {

/// Sets the process's allocator to return large blocks to the system (a fixed mmap threshold of
/// 256 KiB) and to use at most two arenas. Process-wide; call before the threads start. Returns
/// false where the C library has no such settings (not glibc).
bool keepResidentMemoryFlat();

}  // namespace tescalib
