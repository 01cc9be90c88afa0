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

}  // namespace colmap
