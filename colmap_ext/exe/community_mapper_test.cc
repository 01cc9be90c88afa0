#include "colmap_ext/exe/community_mapper.h"

#include "colmap_ext/workflow/community_workspace.h"
#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/scene/database.h"
#include "colmap/util/file.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// The commands in-process, on a small generated database.
class RunCommunityMapperImplTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::filesystem::path test_dir = CreateTestFolder();
    SyntheticSceneOptions scene_options;
    scene_options.num_clusters = 2;
    scene_options.num_images_per_cluster = 12;
    scene_options.num_images_per_link = 6;
    scene_options.num_points_per_cluster = 400;
    scene_options.num_points_per_link = 150;
    scene_options.close_loop = false;
    command_.options.mapper.database_path = (test_dir / "database.db").string();
    {
      const std::shared_ptr<Database> database =
          Database::Open(command_.options.mapper.database_path);
      SyntheticScene scene;
      SynthesizeCommunityScene(scene_options, &scene, database.get());
    }
    command_.options.mapper.output_path = (test_dir / "out").string();
    command_.options.mapper.plan_options =
        "CommunityMapper.modularity_threshold=0.3\n";
    command_.options.mapper.community_detection.min_community_size = 5;
    command_.project_ini = "output_path=" + command_.options.mapper.output_path + "\n";
  }

  CommunityMapperCommand Stage(const CommunityMapperStage stage) const {
    CommunityMapperCommand command = command_;
    command.stage = stage;
    return command;
  }

  CommunityMapperCommand command_;
};

TEST_F(RunCommunityMapperImplTest, PartitionWritesThePlanAndIsIdempotent) {
  const CommunityWorkspace workspace(command_.options.mapper.output_path);
  ASSERT_TRUE(RunCommunityMapperImpl(Stage(CommunityMapperStage::kPartition)));
  ASSERT_TRUE(ExistsFile(workspace.PlanPath()));
  EXPECT_TRUE(ExistsFile(workspace.CommunitiesPath()));
  EXPECT_EQ(ReadTextFile(workspace.ProjectPath()), command_.project_ini);
  const std::string plan = ReadTextFile(workspace.PlanPath());
  EXPECT_GE(CommunityPlanFromText(plan).NumCommunities(), 2);
  // Again with the same database and options: nothing to do.
  EXPECT_TRUE(RunCommunityMapperImpl(Stage(CommunityMapperStage::kPartition)));
  EXPECT_EQ(ReadTextFile(workspace.PlanPath()), plan);
  // With other options: refused, the plan kept.
  CommunityMapperCommand other = Stage(CommunityMapperStage::kPartition);
  other.options.mapper.plan_options = "CommunityMapper.modularity_threshold=0.4\n";
  EXPECT_FALSE(RunCommunityMapperImpl(other));
  EXPECT_EQ(ReadTextFile(workspace.PlanPath()), plan);
  // Unless overwrite: a new plan.
  other.options.overwrite = true;
  EXPECT_TRUE(RunCommunityMapperImpl(other));
  EXPECT_NE(ReadTextFile(workspace.PlanPath()).find("threshold=0.4"),
            std::string::npos);
}

TEST_F(RunCommunityMapperImplTest, LaterStagesNeedAPlanAndItsCommunities) {
  const CommunityWorkspace workspace(command_.options.mapper.output_path);
  EXPECT_FALSE(RunCommunityMapperImpl(Stage(CommunityMapperStage::kMerge)));
  EXPECT_FALSE(ExistsDir(workspace.OutputPath()));
  ASSERT_TRUE(RunCommunityMapperImpl(Stage(CommunityMapperStage::kPartition)));

  CommunityMapperCommand community = Stage(CommunityMapperStage::kCommunity);
  community.community_id = 99;
  EXPECT_FALSE(RunCommunityMapperImpl(community));
  community.community_id = -1;
  EXPECT_FALSE(RunCommunityMapperImpl(community));
  EXPECT_FALSE(ExistsDir(workspace.CommunitiesDir()));

  community.community_id = 0;
  ASSERT_TRUE(RunCommunityMapperImpl(community));
  EXPECT_TRUE(ExistsFile(workspace.CommunityRecordPath(0)));
  // The other communities have no record: no merge.
  EXPECT_FALSE(RunCommunityMapperImpl(Stage(CommunityMapperStage::kMerge)));
  EXPECT_TRUE(workspace.MergedModelPaths().empty());
}

TEST_F(RunCommunityMapperImplTest, BadOptionsWriteNothing) {
  CommunityMapperCommand command = Stage(CommunityMapperStage::kAll);
  command.options.edge_weights = "inliers";
  EXPECT_FALSE(RunCommunityMapperImpl(command));
  command = Stage(CommunityMapperStage::kAll);
  command.options.mapper.community_detection.modularity_threshold = 1.5;
  EXPECT_FALSE(RunCommunityMapperImpl(command));
  command = Stage(CommunityMapperStage::kAll);
  command.options.mapper.database_path += ".missing";
  EXPECT_FALSE(RunCommunityMapperImpl(command));
  EXPECT_FALSE(ExistsDir(command_.options.mapper.output_path));
}

}  // namespace
}  // namespace colmap
