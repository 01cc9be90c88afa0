// Real photographs end to end: COLMAP's own feature extraction (CPU SIFT, one
// PINHOLE camera shared by all images) and exhaustive matching, then
// `colmap community_mapper` and `colmap mapper` on the same database,
// compared with the ground-truth cameras of the Strecha sets in
// ../shared/data/strecha (skipped, with a message, where it is absent).

#include "colmap_ext/workflow/community_io.h"
#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/util/file.h"
#include "colmap/util/logging.h"
#include "colmap/util/string.h"
#include "colmap/util/timer.h"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>

#include <gtest/gtest.h>

namespace colmap {
namespace {

std::filesystem::path DatasetPath(const std::string& name) {
  return std::filesystem::path(SHARED_DATA_DIR) / "strecha" / name;
}

// Extracts and matches once per data set; returns the database path.
std::filesystem::path PrepareDatabase(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / "colmap_ext_tests" /
      "RealData" / name;
  const std::filesystem::path database = dir / "database.db";
  const std::filesystem::path done = dir / "matched";
  if (ExistsFile(done)) {
    return database;
  }
  std::filesystem::remove_all(dir);
  CreateDirIfNotExists(dir, /*recursive=*/true);
  std::string output;
  THROW_CHECK_EQ(
      RunCommand(std::string(COLMAP_BINARY) +
                     " feature_extractor --database_path " +
                     ShellQuote(database) + " --image_path " +
                     ShellQuote(DatasetPath(name) / "images") +
                     " --ImageReader.camera_model PINHOLE"
                     " --ImageReader.single_camera 1"
                     " --FeatureExtraction.use_gpu 0",
                 &output),
      0)
      << output;
  THROW_CHECK_EQ(
      RunCommand(std::string(COLMAP_BINARY) +
                     " exhaustive_matcher --database_path " +
                     ShellQuote(database) + " --FeatureMatching.use_gpu 0",
                 &output),
      0)
      << output;
  std::ofstream(done) << "1\n";
  return database;
}

struct MapperRun {
  std::filesystem::path output_path;
  std::string log;
  double seconds = 0;
  ModelEvaluation evaluation;
};

MapperRun RunMapper(const std::string& name,
                    const std::filesystem::path& database,
                    const std::string& command,
                    const std::string& arguments) {
  MapperRun run;
  run.output_path = GetParentDir(database) / command;
  std::filesystem::remove_all(run.output_path);
  CreateDirIfNotExists(run.output_path);
  Timer timer;
  timer.Start();
  THROW_CHECK_EQ(
      RunCommand(
          std::string(COLMAP_BINARY) + " " + command + " --database_path " +
              ShellQuote(database) + " --image_path " +
              ShellQuote(DatasetPath(name) / "images") +
              " --output_path " + ShellQuote(run.output_path) + " " + arguments,
          &run.log),
      0)
      << run.log;
  run.seconds = timer.ElapsedSeconds();
  Reconstruction model;
  model.Read(run.output_path / "0");
  Reconstruction ground_truth;
  ground_truth.Read(DatasetPath(name) / "ground_truth");
  run.evaluation = EvaluateModel(model, ground_truth);
  return run;
}

void Report(const std::string& name,
            const MapperRun& community,
            const MapperRun& mapper) {
  std::cout << StringPrintf(
                   "%s: community_mapper %.1fs, %d images, median position "
                   "error %.4f m (%.3f%% of %.1f m), rotation %.3f deg, "
                   "reprojection %.3f px | mapper %.1fs, %d images, %.4f m, "
                   "%.3f deg, %.3f px",
                   name.c_str(),
                   community.seconds,
                   community.evaluation.num_registered_images,
                   community.evaluation.median_position_error,
                   100 * community.evaluation.median_position_error /
                       community.evaluation.extent,
                   community.evaluation.extent,
                   community.evaluation.median_rotation_error_deg,
                   community.evaluation.mean_reprojection_error,
                   mapper.seconds,
                   mapper.evaluation.num_registered_images,
                   mapper.evaluation.median_position_error,
                   mapper.evaluation.median_rotation_error_deg,
                   mapper.evaluation.mean_reprojection_error)
            << std::endl;
}

class RealData : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!ExistsDir(std::filesystem::path(SHARED_DATA_DIR) / "strecha")) {
      GTEST_SKIP() << "The Strecha photo sets are not at " << SHARED_DATA_DIR
                   << "/strecha (../shared beside the repository); skipped.";
    }
  }
};

// The courtyard loop: with exhaustive matching nearly every pair is
// verified, so only the inlier-weighted view graph shows the structure, and
// its peak splits only by the balance rule.
TEST_F(RealData, CastleP30SplitsAndMergesAsWellAsTheMapper) {
  const std::filesystem::path database = PrepareDatabase("castle-P30");
  const MapperRun community =
      RunMapper("castle-P30",
                database,
                "community_mapper",
                "--CommunityMapper.edge_weights num_inliers "
                "--CommunityMapper.min_community_size 8 "
                "--CommunityMapper.max_community_fraction 0.5");
  const MapperRun mapper = RunMapper("castle-P30", database, "mapper", "");
  Report("castle-P30", community, mapper);

  const std::unordered_map<std::string, int> communities =
      ReadCommunities(community.output_path / "communities.txt");
  std::set<int> ids;
  for (const auto& entry : communities) {
    ids.insert(entry.second);
  }
  EXPECT_GE(ids.size(), 2);
  EXPECT_FALSE(ExistsDir(community.output_path / "1"));
  EXPECT_EQ(community.evaluation.num_registered_images, 30);
  ASSERT_TRUE(community.evaluation.aligned);
  EXPECT_LE(community.evaluation.median_position_error,
            1.5 * mapper.evaluation.median_position_error);
  EXPECT_LT(community.evaluation.median_position_error,
            0.02 * community.evaluation.extent);
  EXPECT_LT(community.evaluation.mean_reprojection_error, 1.0);

  // The merged model's points are filtered as the incremental mapper
  // filters its own (Mapper.filter_max_reproj_error, 4 px).
  Reconstruction model;
  model.Read(community.output_path / "0");
  for (const auto& point3D : model.Points3D()) {
    EXPECT_LE(point3D.second.error, 4.0 + 0.01);
  }
}

// A facade and its side: no community structure with the defaults, so the
// result is the incremental mapper's.
TEST_F(RealData, HerzJesusP25IsOneCommunity) {
  const std::filesystem::path database = PrepareDatabase("Herz-Jesus-P25");
  const MapperRun community =
      RunMapper("Herz-Jesus-P25", database, "community_mapper", "");
  const MapperRun mapper = RunMapper("Herz-Jesus-P25", database, "mapper", "");
  Report("Herz-Jesus-P25", community, mapper);

  const std::unordered_map<std::string, int> communities =
      ReadCommunities(community.output_path / "communities.txt");
  EXPECT_EQ(communities.size(), 25);
  for (const auto& entry : communities) {
    EXPECT_EQ(entry.second, 0);
  }
  EXPECT_EQ(community.evaluation.num_registered_images, 25);
  EXPECT_EQ(mapper.evaluation.num_registered_images, 25);
  EXPECT_LE(community.evaluation.median_position_error,
            1.5 * mapper.evaluation.median_position_error);
  EXPECT_LT(community.evaluation.median_position_error,
            0.02 * community.evaluation.extent);
  EXPECT_LT(community.evaluation.mean_reprojection_error, 1.0);
}

}  // namespace
}  // namespace colmap
