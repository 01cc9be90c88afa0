// The memory this process holds now and at most so far (Linux:
// /proc/self/status, VmRSS and VmHWM), for the log of a long run: the phase
// after which the peak rose is the phase that set it.

#pragma once

#include <string>

namespace colmap {

struct ProcessMemory {
  // Resident memory now and its peak so far (MB); 0 where unknown.
  double resident_mb = 0.0;
  double peak_resident_mb = 0.0;
};

ProcessMemory ReadProcessMemory();

// "memory 812 MB, peak 1034 MB" (empty where unknown).
std::string ProcessMemoryToString(const ProcessMemory& memory);

// Hands the heap memory that freed allocations left to the process back to
// the system (glibc: malloc_trim; elsewhere nothing). glibc gives every
// thread that allocates an arena of its own and keeps what is freed there
// for that arena: the memory of the community reconstructions, freed on the
// worker threads, would otherwise stay resident while the merge allocates
// anew on the main thread. Returns whether memory was released.
bool ReleaseFreedMemory();

// Makes every allocation of at least `min_bytes` a mapping of its own, handed
// back to the system when it is freed (glibc: mallopt M_MMAP_THRESHOLD;
// elsewhere nothing). glibc raises that threshold by itself after large
// blocks are freed (up to 32 MB), so that the large buffers of a phase
// (keypoints, tracks, solver matrices) are then carved from the heap among
// small blocks that outlive them, and their pages stay resident into the
// next phase. A run whose phases hold different data (communities, then the
// merge) then peaks at the next phase's data plus the last one's remnants;
// with the threshold fixed, less is left and the peak is lower at the same
// run time. Returns whether the threshold was set.
bool MapLargeAllocationsApart(int min_bytes = 128 * 1024);

}  // namespace colmap
