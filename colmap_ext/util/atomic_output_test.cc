#include "colmap_ext/util/atomic_output.h"

#include "colmap_ext/util/testing.h"

#include "colmap/util/misc.h"

#include <fstream>
#include <sstream>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace colmap
