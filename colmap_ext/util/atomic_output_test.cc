#include "colmap_ext/util/atomic_output.h"

#include "colmap_ext/util/testing.h"

#include "colmap/util/misc.h"

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

namespace colmap {
namespace {

std::string ReadText(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

Reconstruction TwoImages() {
  Reconstruction reconstruction;
  reconstruction.AddCamera(
      Camera::CreateFromModelName(1, "PINHOLE", 100, 100, 100));
  for (image_t image_id = 1; image_id <= 2; ++image_id) {
    Image image;
    image.SetImageId(image_id);
    image.SetCameraId(1);
    image.SetName("image" + std::to_string(image_id));
    reconstruction.AddImage(image);
    reconstruction.RegisterImage(image_id);
  }
  return reconstruction;
}

TEST(WriteReconstructionAtomically, ReplacesAModelWithoutLeftovers) {
  const std::string test_dir = CreateTestFolder();
  const std::string path = JoinPaths(test_dir, "0");
  CreateDirIfNotExists(path);
  std::ofstream(JoinPaths(path, "stale.txt")) << "old";
  EXPECT_FALSE(IsModelDir(path));

  WriteReconstructionAtomically(TwoImages(), path);
  EXPECT_TRUE(IsModelDir(path));
  EXPECT_FALSE(ExistsFile(JoinPaths(path, "stale.txt")));
  Reconstruction read;
  read.Read(path);
  EXPECT_EQ(read.NumRegImages(), 2);
  // Only the model is left in the parent folder.
  int num_entries = 0;
  for (const auto& entry : boost::filesystem::directory_iterator(test_dir)) {
    (void)entry;
    ++num_entries;
  }
  EXPECT_EQ(num_entries, 1);
}

TEST(WriteTextFileAtomically, ReplacesTheFile) {
  const std::string path = JoinPaths(CreateTestFolder(), "a.txt");
  WriteTextFileAtomically("first\n", path);
  WriteTextFileAtomically("second\n", path);
  EXPECT_EQ(ReadText(path), "second\n");
}

std::string ThisHost() {
  char name[256] = {};
  THROW_CHECK_EQ(::gethostname(name, sizeof(name) - 1), 0);
  return name;
}

// The id of a process of this host that has ended.
pid_t EndedProcess() {
  const pid_t pid = ::fork();
  THROW_CHECK_GE(pid, 0);
  if (pid == 0) {
    ::_exit(0);
  }
  THROW_CHECK_EQ(::waitpid(pid, nullptr, 0), pid);
  return pid;
}

TEST(RemoveLeftoversOfEndedWriters,
     RemovesOnlyWhatKilledWritersOfThisHostLeft) {
  const std::string folder = CreateTestFolder();
  const std::string ended = ThisHost() + "-" + std::to_string(EndedProcess());
  const std::string running = ThisHost() + "-" + std::to_string(::getppid());
  const auto make_dir = [&](const std::string& name) {
    CreateDirIfNotExists(JoinPaths(folder, name));
    std::ofstream(JoinPaths(folder, name, "cameras.bin")) << "x";
  };
  // A killed writer's half-written model, and a record's temporary.
  make_dir("0.tmp-" + ended);
  std::ofstream(JoinPaths(folder, "0.txt.tmp-" + ended)) << "half";
  // A killed writer's previous output, moved aside: garbage where the
  // output is back, the only copy where it is not.
  make_dir("1");
  make_dir("1.old-" + ended);
  make_dir("2.old-" + ended);
  // What a running process or another host's is writing.
  make_dir("3.tmp-" + running);
  make_dir("4.tmp-otherhost-" + std::to_string(EndedProcess()));
  // A killed writer that nobody reaped yet.
  const pid_t zombie = ::fork();
  ASSERT_GE(zombie, 0);
  if (zombie == 0) {
    ::_exit(0);
  }
  const std::string zombie_tag = ThisHost() + "-" + std::to_string(zombie);
  make_dir("6.tmp-" + zombie_tag);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));

  // A writer of another output in the folder clears them.
  WriteTextFileAtomically("record\n", JoinPaths(folder, "5.txt"));
  EXPECT_FALSE(ExistsDir(JoinPaths(folder, "0.tmp-" + ended)));
  EXPECT_FALSE(ExistsFile(JoinPaths(folder, "0.txt.tmp-" + ended)));
  EXPECT_FALSE(ExistsDir(JoinPaths(folder, "1.old-" + ended)));
  EXPECT_TRUE(ExistsDir(JoinPaths(folder, "1")));
  EXPECT_TRUE(ExistsDir(JoinPaths(folder, "2.old-" + ended)));
  EXPECT_TRUE(ExistsDir(JoinPaths(folder, "3.tmp-" + running)));
  EXPECT_FALSE(ExistsDir(JoinPaths(folder, "6.tmp-" + zombie_tag)));
  EXPECT_EQ(::waitpid(zombie, nullptr, 0), zombie);
  EXPECT_EQ(RemoveLeftoversOfEndedWriters(folder), 0);
  int num_entries = 0;
  for (const auto& entry : boost::filesystem::directory_iterator(folder)) {
    (void)entry;
    ++num_entries;
  }
  EXPECT_EQ(num_entries, 5);  // 1, 2.old-, 3.tmp-, 4.tmp-, 5.txt
}

}  // namespace
}  // namespace colmap
