// Bad input to `colmap community_mapper`: each case must end with a message
// naming the problem and what to do, a non-zero exit, and nothing written.

#include "colmap_ext/testing/testing.h"

#include "colmap/scene/database.h"
#include "colmap/util/file.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <system_error>

#include <gtest/gtest.h>

namespace colmap {
namespace {

std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file),
                     std::istreambuf_iterator<char>());
}

// Runs community_mapper; returns its exit status and output.
int RunCommunityMapper(const std::filesystem::path& database_path,
                       const std::filesystem::path& image_path,
                       const std::filesystem::path& output_path,
                       const std::string& extra_arguments,
                       std::string* output) {
  return RunCommand(std::string(COLMAP_BINARY) +
                        " community_mapper --database_path " +
                        ShellQuote(database_path) + " --image_path " +
                        ShellQuote(image_path) + " --output_path " +
                        ShellQuote(output_path) + " " + extra_arguments,
                    output);
}

// `colmap community_partitioner` on them.
int RunPartitioner(const std::filesystem::path& database_path,
                   const std::filesystem::path& image_path,
                   const std::filesystem::path& output_path,
                   const std::string& extra_arguments,
                   std::string* output) {
  return RunCommand(std::string(COLMAP_BINARY) +
                        " community_partitioner --database_path " +
                        ShellQuote(database_path) + " --image_path " +
                        ShellQuote(image_path) + " --output_path " +
                        ShellQuote(output_path) + " " + extra_arguments,
                    output);
}

// A database with `num_images` images; with keypoints if asked; pairs
// (i, i+1) verified with 50 inlier matches if asked.
void CreateDatabase(const std::filesystem::path& path,
                    const int num_images,
                    const bool with_keypoints,
                    const bool with_matches) {
  const std::shared_ptr<Database> database = Database::Open(path);
  const camera_t camera_id = database->WriteCamera(Camera::CreateFromModelName(
      kInvalidCameraId, "SIMPLE_RADIAL", 500, 640, 480));
  std::vector<image_t> image_ids;
  for (int i = 0; i < num_images; ++i) {
    Image image;
    image.SetName("image" + std::to_string(i) + ".jpg");
    image.SetCameraId(camera_id);
    image_ids.push_back(database->WriteImage(image));
    if (with_keypoints) {
      database->WriteKeypoints(image_ids.back(),
                               FeatureKeypoints(100, FeatureKeypoint(1, 1)));
    }
  }
  if (with_matches) {
    for (int i = 0; i + 1 < num_images; ++i) {
      TwoViewGeometry two_view_geometry;
      two_view_geometry.config = TwoViewGeometry::CALIBRATED;
      for (int k = 0; k < 50; ++k) {
        two_view_geometry.inlier_matches.emplace_back(k, k);
      }
      database->WriteTwoViewGeometry(
          image_ids[i], image_ids[i + 1], two_view_geometry);
    }
  }
}

class CommunityMapperInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test_dir_ = CreateTestFolder();
    image_path_ = test_dir_ / "images";
    CreateDirIfNotExists(image_path_);
    output_path_ = test_dir_ / "out";
    good_database_ = test_dir_ / "good.db";
    CreateDatabase(good_database_, 4, true, true);
  }

  // Runs with the given arguments and expects a refusal whose message
  // contains `expected`, with nothing written to the output folder.
  void ExpectRefusal(const std::filesystem::path& database_path,
                     const std::string& extra_arguments,
                     const std::string& expected) {
    std::string output;
    EXPECT_EQ(
        RunCommunityMapper(
            database_path, image_path_, output_path_, extra_arguments, &output),
        EXIT_FAILURE)
        << output;
    EXPECT_NE(output.find(expected), std::string::npos)
        << "expected \"" << expected << "\" in:\n"
        << output;
    EXPECT_FALSE(std::filesystem::exists(output_path_)) << output;
  }

  std::filesystem::path test_dir_;
  std::filesystem::path image_path_;
  std::filesystem::path output_path_;
  std::filesystem::path good_database_;
};

TEST_F(CommunityMapperInputTest, MissingDatabase) {
  ExpectRefusal(test_dir_ / "missing.db", "", "does not exist");
  // Nor is an empty database created in its place.
  EXPECT_FALSE(ExistsFile(test_dir_ / "missing.db"));
}

TEST_F(CommunityMapperInputTest, FileThatIsNoDatabase) {
  const std::filesystem::path path = test_dir_ / "notes.db";
  std::ofstream(path) << "these are not the images you are looking for\n";
  ExpectRefusal(path, "", "Cannot read the database");
}

TEST_F(CommunityMapperInputTest, DatabaseWithoutImages) {
  const std::filesystem::path path = test_dir_ / "empty.db";
  CreateDatabase(path, 0, false, false);
  ExpectRefusal(path, "", "has no images: run `colmap feature_extractor`");
}

TEST_F(CommunityMapperInputTest, DatabaseWithoutFeatures) {
  const std::filesystem::path path = test_dir_ / "no_features.db";
  CreateDatabase(path, 4, false, false);
  ExpectRefusal(path, "", "no features: run `colmap feature_extractor`");
}

TEST_F(CommunityMapperInputTest, DatabaseWithoutVerifiedPairs) {
  const std::filesystem::path path = test_dir_ / "no_matches.db";
  CreateDatabase(path, 4, true, false);
  ExpectRefusal(path, "", "no verified image pairs");
  ExpectRefusal(path, "", "run a matcher first");
}

TEST_F(CommunityMapperInputTest, ImagesThatFailFeatureExtraction) {
  // Files named like photos that are none: COLMAP's feature extractor
  // skips them, and community_mapper says which step to look at.
  for (const std::string name : {"a.jpg", "b.jpg", "c.jpg"}) {
    std::ofstream(image_path_ / name) << "not a photo";
  }
  const std::filesystem::path path = test_dir_ / "extracted.db";
  std::string output;
  RunCommand(std::string(COLMAP_BINARY) +
                 " feature_extractor --FeatureExtraction.use_gpu 0"
                 " --database_path " +
                 ShellQuote(path) + " --image_path " + ShellQuote(image_path_),
             &output);
  ExpectRefusal(path, "", "run `colmap feature_extractor`");
}

TEST_F(CommunityMapperInputTest, TooFewInliersForTheThreshold) {
  // The pairs have 50 inliers; asking for 60 leaves none.
  ExpectRefusal(good_database_,
                "--Mapper.min_num_matches 60",
                "no verified image pairs with at least 60 inlier matches");
}

TEST_F(CommunityMapperInputTest, BadImageList) {
  const std::filesystem::path path = test_dir_ / "images.txt";
  ExpectRefusal(good_database_,
                "--image_list_path " + ShellQuote(path),
                "does not exist. Check --image_list_path");
  std::ofstream(path) << "\n  \n";
  ExpectRefusal(good_database_,
                "--image_list_path " + ShellQuote(path),
                "names no image");
  std::ofstream(path) << "image0.jpg\nimages/image1.jpg\nimage2.jpg\n";
  ExpectRefusal(good_database_,
                "--image_list_path " + ShellQuote(path),
                "1 of the 3 names in the image list " + path.string() +
                    " are no image of the database " + good_database_.string() +
                    ", e.g. 'images/image1.jpg'");
}

TEST_F(CommunityMapperInputTest, InvalidOptionValues) {
  ExpectRefusal(good_database_,
                "--CommunityMapper.modularity_threshold 1.0",
                "modularity_threshold is 1: it must be in [0, 1)");
  ExpectRefusal(good_database_,
                "--CommunityMapper.modularity_threshold -0.1",
                "modularity_threshold is -0.1: it must be in [0, 1)");
  ExpectRefusal(good_database_,
                "--CommunityMapper.min_community_size 1",
                "min_community_size is 1: it must be at least 2");
  ExpectRefusal(good_database_,
                "--CommunityMapper.max_community_fraction 0",
                "max_community_fraction is 0: it must be in (0, 1]");
  ExpectRefusal(good_database_,
                "--CommunityMapper.partition_max_part_conductance 1.5",
                "--CommunityMapper.partition_max_part_conductance is 1.5: it "
                "must be in (0, 1]");
  ExpectRefusal(good_database_,
                "--CommunityMapper.edge_weights inliers",
                "edge_weights is 'inliers': use 'unit' or 'num_inliers'");
  ExpectRefusal(
      good_database_, "--CommunityMapper.num_workers 0", "num_workers is 0");
  ExpectRefusal(good_database_,
                "--CommunityMapper.image_overlap -1",
                "image_overlap is -1");
  ExpectRefusal(good_database_,
                "--CommunityMapper.pairwise_min_num_inliers 2",
                "--CommunityMapper.pairwise_min_num_inliers is 2: it must be "
                "at least 3");
  ExpectRefusal(good_database_,
                "--CommunityMapper.averaging_max_relative_displacement 0",
                "--CommunityMapper.averaging_max_relative_displacement is 0: "
                "it must be positive");
}

TEST_F(CommunityMapperInputTest, OutputPathIsAFile) {
  std::ofstream(output_path_) << "a file\n";
  std::string output;
  EXPECT_EQ(RunCommunityMapper(
                good_database_, image_path_, output_path_, "", &output),
            EXIT_FAILURE);
  EXPECT_NE(output.find("is a file, not a folder"), std::string::npos)
      << output;
  EXPECT_EQ(ReadFile(output_path_), "a file\n");
}

TEST_F(CommunityMapperInputTest, OutputPathNotWritable) {
  // Even root may not create folders in /sys.
  const std::string unwritable = "/sys/colmap_ext_test_output";
  std::error_code error;
  if (std::filesystem::create_directory(unwritable, error)) {
    std::filesystem::remove(unwritable);
    GTEST_SKIP() << "/sys is writable here; cannot test an unwritable path";
  }
  std::string output;
  EXPECT_EQ(
      RunCommunityMapper(good_database_, image_path_, unwritable, "", &output),
      EXIT_FAILURE);
  EXPECT_NE(output.find("Cannot create --output_path"), std::string::npos)
      << output;

  // An existing folder without write permission.
  EXPECT_EQ(RunCommunityMapper(
                good_database_, image_path_, "/sys/kernel", "", &output),
            EXIT_FAILURE);
  EXPECT_NE(output.find("is not writable"), std::string::npos) << output;
}

TEST_F(CommunityMapperInputTest, EarlierResultsAreNotReplacedSilently) {
  // An earlier model in OUT/0.
  const std::filesystem::path model_path = output_path_ / "0";
  CreateDirIfNotExists(model_path, /*recursive=*/true);
  for (const std::string name : {"cameras.bin", "images.bin", "points3D.bin"}) {
    std::ofstream(model_path / name) << name;
  }
  std::string output;
  EXPECT_EQ(RunPartitioner(good_database_, image_path_, output_path_, "", &output),
            EXIT_FAILURE);
  EXPECT_NE(output.find("already holds results of an earlier run"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("--CommunityMapper.overwrite 1"), std::string::npos);
  EXPECT_EQ(ReadFile(model_path / "cameras.bin"), "cameras.bin");
  EXPECT_FALSE(ExistsFile(output_path_ / "communities.txt"));

  // With permission, the run goes ahead.
  EXPECT_EQ(RunPartitioner(good_database_,
                           image_path_,
                           output_path_,
                           "--CommunityMapper.overwrite 1",
                           &output),
            0)
      << output;
  EXPECT_TRUE(ExistsFile(output_path_ / "communities.txt"));
  // The earlier model does not belong to the new partition.
  EXPECT_FALSE(ExistsDir(model_path));
}

TEST_F(CommunityMapperInputTest, OptionsBesideAProjectFileAreRefused) {
  // COLMAP reads every option from the project file: one given beside it
  // would be dropped silently.
  const std::filesystem::path project_path = output_path_ / "project.ini";
  for (const std::string command : {"community_merger",
                                    "community_reconstructor --community_id 0",
                                    "community_mapper"}) {
    std::string output;
    EXPECT_NE(RunCommand(std::string(COLMAP_BINARY) + " " + command +
                             " --project_path " + ShellQuote(project_path) +
                             " --CommunityMapper.skip_registration=1",
                         &output),
              0)
        << command;
    EXPECT_NE(output.find("--CommunityMapper.skip_registration on the "
                          "command line would be ignored"),
              std::string::npos)
        << command << ": " << output;
  }
}

// The help lists at most 25 --CommunityMapper options, and docs/options.md
// exactly those, with the same defaults.
TEST_F(CommunityMapperInputTest, HelpMatchesTheOptionsDoc) {
  std::string help;
  ASSERT_EQ(
      RunCommand(std::string(COLMAP_BINARY) + " community_mapper -h", &help),
      0);
  EXPECT_NE(help.find("--Mapper.min_num_matches arg (=15)"), std::string::npos);
  EXPECT_NE(help.find("--project_path"), std::string::npos);
  std::map<std::string, std::string> help_defaults;
  const std::regex help_option(
      R"(--CommunityMapper\.([a-z_0-9]+) arg \(=([^)]*)\))");
  for (std::sregex_iterator it(help.begin(), help.end(), help_option), end;
       it != end;
       ++it) {
    help_defaults[(*it)[1]] = (*it)[2];
  }
  EXPECT_GE(help_defaults.size(), 9);
  EXPECT_LE(help_defaults.size(), 25);

  const std::string doc =
      ReadFile(std::filesystem::path(SOURCE_DIR) / "docs" / "options.md");
  std::map<std::string, std::string> doc_defaults;
  const std::regex doc_option(R"(\n\| `([a-z_0-9]+)` \| ([^ |]*) \|)");
  for (std::sregex_iterator it(doc.begin(), doc.end(), doc_option), end;
       it != end;
       ++it) {
    doc_defaults[(*it)[1]] = (*it)[2];
  }
  EXPECT_EQ(doc_defaults.size(), help_defaults.size())
      << "regenerate docs/options.md: build/community_mapper_options_doc > "
         "docs/options.md";
  for (const auto& help_default : help_defaults) {
    const std::string& name = help_default.first;
    const std::string& value = help_default.second;
    const auto it = doc_defaults.find(name);
    ASSERT_NE(it, doc_defaults.end()) << name << " is not in docs/options.md";
    // The help prints doubles to 3 significant digits (%.3g).
    char* end = nullptr;
    const double help_value = std::strtod(value.c_str(), &end);
    if (end != value.c_str() && *end == '\0') {
      EXPECT_NEAR(
          std::stod(it->second), help_value, 5e-3 * std::abs(help_value))
          << name;
    } else {
      EXPECT_EQ(it->second, value) << name;
    }
  }
}

}  // namespace
}  // namespace colmap
