#include "colmap_ext/util/process_memory.h"

#include "colmap/util/string.h"

#include <fstream>
#include <sstream>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace colmap {

ProcessMemory ReadProcessMemory() {
  ProcessMemory memory;
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    std::istringstream fields(line);
    std::string key;
    double kilobytes = 0.0;
    fields >> key >> kilobytes;
    if (fields.fail()) {
      continue;
    }
    if (key == "VmRSS:") {
      memory.resident_mb = kilobytes / 1024.0;
    } else if (key == "VmHWM:") {
      memory.peak_resident_mb = kilobytes / 1024.0;
    }
  }
  return memory;
}

std::string ProcessMemoryToString(const ProcessMemory& memory) {
  if (memory.peak_resident_mb <= 0) {
    return "";
  }
  return StringPrintf("memory %.0f MB, peak %.0f MB",
                      memory.resident_mb,
                      memory.peak_resident_mb);
}

bool ReleaseFreedMemory() {
#if defined(__GLIBC__)
  return malloc_trim(0) != 0;
#else
  return false;
#endif
}

bool MapLargeAllocationsApart(const int min_bytes) {
#if defined(__GLIBC__)
  return mallopt(M_MMAP_THRESHOLD, min_bytes) == 1;
#else
  return false;
#endif
}

}  // namespace colmap
