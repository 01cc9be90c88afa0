#include "colmap_ext/workflow/output_lock.h"

#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/util/file.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

namespace colmap {
namespace {

std::string ReadLine(const std::string& path) {
  std::ifstream file(path);
  std::string line;
  std::getline(file, line);
  return line;
}

TEST(OutputLock, OneHolderAtATime) {
  const std::string folder = CreateTestFolder();
  const std::string path =
      (std::filesystem::path(folder) / kOutputLockFileName).string();
  {
    OutputLock first;
    ASSERT_EQ(first.Acquire(folder), "");
    EXPECT_EQ(ReadLine(path), WriterTag());
    // A second run (here: the same process again) is refused, naming the
    // holder.
    OutputLock second;
    const std::string refusal = second.Acquire(folder);
    EXPECT_NE(refusal.find("Another run is writing " + folder),
              std::string::npos)
        << refusal;
    EXPECT_NE(refusal.find("process " + std::to_string(::getpid()) +
                           " on host " + HostName()),
              std::string::npos)
        << refusal;
    EXPECT_EQ(ReadLine(path), WriterTag());
  }
  // Released with its holder.
  EXPECT_FALSE(ExistsFile(path));
  OutputLock again;
  EXPECT_EQ(again.Acquire(folder), "");
  again.Release();
  EXPECT_FALSE(ExistsFile(path));
}

TEST(OutputLock, LockOfAnEndedRunIsTakenOver) {
  const std::string folder = CreateTestFolder();
  const std::string path =
      (std::filesystem::path(folder) / kOutputLockFileName).string();
  // A process of this host that has ended (reaped).
  const pid_t child = ::fork();
  if (child == 0) {
    ::_exit(0);
  }
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  std::ofstream(path) << HostName() << "-" << child << "\n";
  OutputLock lock;
  EXPECT_EQ(lock.Acquire(folder), "");
  EXPECT_EQ(ReadLine(path), WriterTag());
}

TEST(OutputLock, LockOfARunningProcessOrAnotherHostStays) {
  const std::string folder = CreateTestFolder();
  const std::string path =
      (std::filesystem::path(folder) / kOutputLockFileName).string();
  // The parent of this test runs.
  const std::string running = HostName() + "-" + std::to_string(::getppid());
  std::ofstream(path) << running << "\n";
  OutputLock lock;
  EXPECT_NE(lock.Acquire(folder).find(
                "process " + std::to_string(::getppid()) + " on host"),
            std::string::npos);
  EXPECT_EQ(ReadLine(path), running);
  // Another host's process: this host cannot tell whether it runs.
  std::ofstream(path) << "another-host-1\n";
  const std::string refusal = lock.Acquire(folder);
  EXPECT_NE(refusal.find("process 1 on host another-host"), std::string::npos)
      << refusal;
  EXPECT_NE(refusal.find("delete " + path), std::string::npos) << refusal;
  EXPECT_EQ(ReadLine(path), "another-host-1");
}

}  // namespace
}  // namespace colmap
