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

}  // namespace colmap
