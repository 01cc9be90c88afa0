#include "colmap_ext/util/process_memory.h"

#include <vector>

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(ReadProcessMemory, PeakFollowsAnAllocation) {
  const ProcessMemory before = ReadProcessMemory();
  ASSERT_GT(before.resident_mb, 0);
  EXPECT_GE(before.peak_resident_mb, before.resident_mb);
  {
    // 200 MB, touched so that it is resident.
    std::vector<char> block(200 << 20, 1);
    const ProcessMemory during = ReadProcessMemory();
    EXPECT_GT(during.resident_mb, before.resident_mb + 150);
    EXPECT_EQ(block[12345], 1);
  }
  const ProcessMemory after = ReadProcessMemory();
  EXPECT_GT(after.peak_resident_mb, before.resident_mb + 150);
  EXPECT_NE(ProcessMemoryToString(after).find(" MB, peak "), std::string::npos);
}

}  // namespace
}  // namespace colmap
