#include "colmap_ext/util/process_memory.h"

#include <algorithm>
#include <memory>
#include <thread>
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

#if defined(__GLIBC__)
TEST(ReleaseFreedMemory, ReturnsWhatAWorkerThreadFreed) {
  // A worker allocates 200 MB in small blocks (as a reconstruction does)
  // and frees them but for one allocated last, which outlives it (as the
  // community's record does): the heap keeps the memory below that block
  // resident until it is handed back.
  double during_mb = 0;
  std::unique_ptr<char[]> survivor;
  std::thread worker([&during_mb, &survivor]() {
    std::vector<std::unique_ptr<char[]>> blocks;
    for (int i = 0; i < 200 * 1024; ++i) {
      blocks.emplace_back(new char[1000]);
      std::fill(blocks.back().get(), blocks.back().get() + 1000, 1);
    }
    during_mb = ReadProcessMemory().resident_mb;
    survivor.reset(new char[1000]);
  });
  worker.join();
  EXPECT_GT(ReadProcessMemory().resident_mb, during_mb - 50);
  EXPECT_TRUE(ReleaseFreedMemory());
  EXPECT_LT(ReadProcessMemory().resident_mb, during_mb - 100);
}

TEST(MapLargeAllocationsApart, FreedLargeBlocksLeaveAtOnce) {
  ASSERT_TRUE(MapLargeAllocationsApart());
  {
    // Freeing a 16 MB mapping would raise glibc's own threshold to 16 MB.
    std::unique_ptr<char[]> block(new char[16 << 20]);
    std::fill(block.get(), block.get() + (16 << 20), 1);
  }
  // 100 blocks of 1 MB, each followed by a small block that outlives it (as
  // a phase's buffers among the records it leaves): with the threshold
  // left to rise, they would lie in the heap between the small ones and
  // stay resident when freed.
  std::vector<std::unique_ptr<char[]>> large;
  std::vector<std::unique_ptr<char[]>> small;
  for (int i = 0; i < 100; ++i) {
    large.emplace_back(new char[1 << 20]);
    std::fill(large.back().get(), large.back().get() + (1 << 20), 1);
    small.emplace_back(new char[64]);
  }
  const double during_mb = ReadProcessMemory().resident_mb;
  large.clear();
  EXPECT_LT(ReadProcessMemory().resident_mb, during_mb - 80);
}
#endif

}  // namespace
}  // namespace colmap
