#include "colmap_ext/workflow/atomic_output.h"

#include "colmap_ext/testing/testing.h"

#include "colmap/util/file.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

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
  reconstruction.AddCameraWithTrivialRig(
      Camera::CreateFromModelName(1, "PINHOLE", 100, 100, 100));
  for (image_t image_id = 1; image_id <= 2; ++image_id) {
    Image image;
    image.SetImageId(image_id);
    image.SetCameraId(1);
    image.SetName("image" + std::to_string(image_id));
    reconstruction.AddImageWithTrivialFrame(image, Rigid3d());
  }
  return reconstruction;
}

int NumEntries(const std::filesystem::path& folder) {
  int num_entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    (void)entry;
    ++num_entries;
  }
  return num_entries;
}

TEST(WriteReconstructionAtomically, ReplacesAModelWithoutLeftovers) {
  const std::filesystem::path test_dir = CreateTestFolder();
  const std::filesystem::path path = test_dir / "0";
  CreateDirIfNotExists(path);
  std::ofstream(path / "stale.txt") << "old";
  EXPECT_FALSE(IsModelDir(path.string()));

  WriteReconstructionAtomically(TwoImages(), path.string());
  EXPECT_TRUE(IsModelDir(path.string()));
  EXPECT_FALSE(ExistsFile(path / "stale.txt"));
  for (const std::string name :
       {"rigs", "cameras", "frames", "images", "points3D"}) {
    EXPECT_TRUE(ExistsFile(path / (name + ".bin"))) << name;
  }
  EXPECT_EQ(NumEntries(path), 5);
  Reconstruction read;
  read.Read(path);
  EXPECT_EQ(read.NumRegImages(), 2);
  EXPECT_EQ(read.NumRigs(), 1);
  EXPECT_EQ(read.NumRegFrames(), 2);
  // Only the model is left in the parent folder.
  EXPECT_EQ(NumEntries(test_dir), 1);
}

TEST(IsModelDir, AcceptsModelsWithOrWithoutRigsAndFrames) {
  const std::filesystem::path path = CreateTestFolder();
  EXPECT_FALSE(IsModelDir(path.string()));
  // A model of cameras, images and points alone (no rigs and frames).
  for (const std::string name : {"cameras", "images", "points3D"}) {
    std::ofstream(path / (name + ".bin")) << "x";
  }
  EXPECT_TRUE(IsModelDir(path.string()));
  std::ofstream(path / "rigs.bin") << "x";
  std::ofstream(path / "frames.bin") << "x";
  EXPECT_TRUE(IsModelDir(path.string()));
}

TEST(WriteTextFileAtomically, ReplacesTheFile) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "a.txt").string();
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
  const std::filesystem::path folder_path = folder;
  const std::string ended = ThisHost() + "-" + std::to_string(EndedProcess());
  const std::string running = ThisHost() + "-" + std::to_string(::getppid());
  const auto make_dir = [&](const std::string& name) {
    CreateDirIfNotExists(folder_path / name);
    std::ofstream(folder_path / name / "cameras.bin") << "x";
  };
  // A killed writer's half-written model, and a record's temporary.
  make_dir("0.tmp-" + ended);
  std::ofstream(folder_path / ("0.txt.tmp-" + ended)) << "half";
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
  WriteTextFileAtomically("record\n", (folder_path / "5.txt").string());
  EXPECT_FALSE(ExistsDir(folder_path / ("0.tmp-" + ended)));
  EXPECT_FALSE(ExistsFile(folder_path / ("0.txt.tmp-" + ended)));
  EXPECT_FALSE(ExistsDir(folder_path / ("1.old-" + ended)));
  EXPECT_TRUE(ExistsDir(folder_path / "1"));
  EXPECT_TRUE(ExistsDir(folder_path / ("2.old-" + ended)));
  EXPECT_TRUE(ExistsDir(folder_path / ("3.tmp-" + running)));
  EXPECT_FALSE(ExistsDir(folder_path / ("6.tmp-" + zombie_tag)));
  EXPECT_EQ(::waitpid(zombie, nullptr, 0), zombie);
  EXPECT_EQ(RemoveLeftoversOfEndedWriters(folder), 0);
  EXPECT_EQ(NumEntries(folder_path), 5);  // 1, 2.old-, 3.tmp-, 4.tmp-, 5.txt
}

}  // namespace
}  // namespace colmap
