#include "colmap_ext/workflow/community_workspace.h"

#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/util/file.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

namespace colmap {
namespace {

CommunityPlan ExamplePlan() {
  CommunityPlan plan;
  plan.database_path = "/data/my scene/database.db";
  plan.database_fingerprint = "0123456789abcdef";
  plan.options =
      "CommunityMapper.modularity_threshold=0.3\nMapper.min_num_matches=15\n";
  plan.max_modularity = 0.4321;
  plan.num_view_graph_components = 2;
  plan.communities.resize(2);
  plan.communities[0].own_image_names = {"a.jpg", "b c.jpg"};
  plan.communities[0].borrowed_image_names = {"d.jpg"};
  plan.communities[1].own_image_names = {"d.jpg", "sub/e.jpg"};
  plan.communities[1].borrowed_image_names = {"b c.jpg"};
  return plan;
}

TEST(CommunityPlan, TextRoundTrip) {
  const CommunityPlan plan = ExamplePlan();
  const CommunityPlan read = CommunityPlanFromText(CommunityPlanToText(plan));
  EXPECT_EQ(read.database_path, plan.database_path);
  EXPECT_EQ(read.database_fingerprint, plan.database_fingerprint);
  EXPECT_EQ(read.options, plan.options);
  EXPECT_EQ(read.max_modularity, plan.max_modularity);
  EXPECT_EQ(read.num_view_graph_components, plan.num_view_graph_components);
  ASSERT_EQ(read.NumCommunities(), 2);
  for (int c = 0; c < 2; ++c) {
    EXPECT_EQ(read.communities[c].own_image_names,
              plan.communities[c].own_image_names);
    EXPECT_EQ(read.communities[c].borrowed_image_names,
              plan.communities[c].borrowed_image_names);
  }
}

TEST(CommunityPlan, MalformedOrTruncatedPlansAreRefused) {
  const std::string text = CommunityPlanToText(ExamplePlan());
  // Cut before the options end.
  EXPECT_THROW(CommunityPlanFromText(text.substr(0, text.find("end_options"))),
               std::invalid_argument);
  // An image of a community outside the plan.
  EXPECT_THROW(CommunityPlanFromText(text + "image 5 own x.jpg\n"),
               std::invalid_argument);
  EXPECT_THROW(CommunityPlanFromText(text + "something else\n"),
               std::invalid_argument);
  EXPECT_THROW(CommunityPlanFromText(""), std::invalid_argument);
}

TEST(PlanMismatch, NamesTheOptionOrTheDatabase) {
  const CommunityPlan plan = ExamplePlan();
  EXPECT_EQ(PlanMismatch(plan, plan.database_fingerprint, plan.options), "");
  const std::string changed_option = PlanMismatch(
      plan,
      plan.database_fingerprint,
      "CommunityMapper.modularity_threshold=0.4\nMapper.min_num_matches=15\n");
  EXPECT_NE(changed_option.find("CommunityMapper.modularity_threshold is 0.4"),
            std::string::npos)
      << changed_option;
  EXPECT_NE(changed_option.find("0.3"), std::string::npos);
  EXPECT_NE(PlanMismatch(plan, "fedcba9876543210", plan.options)
                .find("other images or verified pairs"),
            std::string::npos);
  EXPECT_NE(PlanMismatch(plan,
                         plan.database_fingerprint,
                         "CommunityMapper.modularity_threshold=0.3\n"),
            "");
}

TEST(DatabaseFingerprint, FollowsImagesFramesAndVerifiedPairs) {
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 6;
  options.num_images_per_link = 4;
  options.num_points_per_cluster = 300;
  options.num_points_per_link = 100;
  options.close_loop = false;
  SyntheticScene scene;
  const std::shared_ptr<Database> database = Database::Open(
      std::filesystem::path(CreateTestFolder()) / "database.db");
  SynthesizeCommunityScene(options, &scene, database.get());
  const std::string fingerprint = DatabaseFingerprint(*database);
  EXPECT_EQ(fingerprint.size(), 16);
  EXPECT_EQ(DatabaseFingerprint(*database), fingerprint);

  // One verified pair fewer.
  const std::vector<std::pair<image_pair_t, int>> num_inliers =
      database->ReadTwoViewGeometryNumInliers();
  ASSERT_FALSE(num_inliers.empty());
  const auto [image_id1, image_id2] = PairIdToImagePair(num_inliers[0].first);
  const TwoViewGeometry geometry =
      database->ReadTwoViewGeometry(image_id1, image_id2);
  database->DeleteInlierMatches(image_id1, image_id2);
  EXPECT_NE(DatabaseFingerprint(*database), fingerprint);
  database->UpdateTwoViewGeometry(image_id1, image_id2, geometry);
  EXPECT_EQ(DatabaseFingerprint(*database), fingerprint);

  // The images grouped into frames otherwise (as by rig_configurator).
  const std::vector<Frame> frames = database->ReadAllFrames();
  ASSERT_EQ(frames.size(), database->NumImages());
  database->ClearFrames();
  EXPECT_NE(DatabaseFingerprint(*database), fingerprint);
  for (const Frame& frame : frames) {
    database->WriteFrame(frame, /*use_frame_id=*/true);
  }
  EXPECT_EQ(DatabaseFingerprint(*database), fingerprint);
}

// A community of 57 images, 55 of them in the largest of its 3 models.
CommunityRecord SampleRecord() {
  CommunityRecord record;
  record.community_id = 3;
  record.num_images = 57;
  record.num_registered = 55;
  record.num_points = 4242;
  record.num_models = 3;
  record.num_other_models = 1;
  record.mean_reprojection_error = 0.812345;
  record.seconds = 12.5;
  record.database_fingerprint = "0123456789abcdef";
  return record;
}

TEST(CommunityRecord, TextRoundTrip) {
  const CommunityRecord record = SampleRecord();
  const CommunityRecord read =
      CommunityRecordFromText(CommunityRecordToText(record));
  EXPECT_EQ(read.community_id, 3);
  EXPECT_EQ(read.num_images, 57);
  EXPECT_EQ(read.num_registered, 55);
  EXPECT_EQ(read.num_points, 4242);
  EXPECT_EQ(read.num_models, 3);
  EXPECT_EQ(read.num_other_models, 1);
  EXPECT_NEAR(read.mean_reprojection_error, 0.812345, 1e-6);
  EXPECT_NEAR(read.seconds, 12.5, 1e-3);
  EXPECT_EQ(read.database_fingerprint, record.database_fingerprint);
  EXPECT_THROW(CommunityRecordFromText("community 3\n"), std::invalid_argument);
  // A record without the line has no other model.
  std::string old_text = CommunityRecordToText(record);
  old_text.erase(old_text.find("num_other_models"),
                 std::string("num_other_models 1\n").size());
  EXPECT_EQ(CommunityRecordFromText(old_text).num_other_models, 0);
}

TEST(CommunityRecord, DescribedForTheLog) {
  CommunityRecord record = SampleRecord();
  EXPECT_EQ(DescribeCommunityRecord(record),
            "Community 3 done: 55 of 57 images registered in the largest of "
            "3 models (1 kept beside it), 4242 points (12.5s)");
  record.num_models = 1;
  record.num_other_models = 0;
  EXPECT_EQ(DescribeCommunityRecord(record),
            "Community 3 done: 55 of 57 images registered, 4242 points "
            "(12.5s)");
  record.num_registered = 0;
  EXPECT_EQ(DescribeCommunityRecord(record),
            "Community 3 (57 images) could not be reconstructed; it takes no "
            "part in the merge.");
}

TEST(CommunityWorkspace, ResultsAreFoundAndRemoved) {
  const CommunityWorkspace workspace(
      (std::filesystem::path(CreateTestFolder()) / "out").string());
  EXPECT_EQ(workspace.CreateOutputFolder(), "");
  EXPECT_FALSE(workspace.HasResults());

  Reconstruction model;
  model.AddCameraWithTrivialRig(
      Camera::CreateFromModelName(1, "PINHOLE", 100, 64, 48));
  std::vector<std::shared_ptr<const Reconstruction>> models = {
      std::make_shared<Reconstruction>(model),
      std::make_shared<Reconstruction>(model),
      std::make_shared<Reconstruction>(model)};
  workspace.WriteMergedModels(models);
  EXPECT_TRUE(workspace.HasResults());
  EXPECT_EQ(workspace.MergedModelPaths().size(), 3);
  // A later merge with fewer models leaves no stale model behind.
  models.pop_back();
  workspace.WriteMergedModels(models);
  EXPECT_EQ(workspace.MergedModelPaths().size(), 2);
  EXPECT_FALSE(ExistsDir(workspace.MergedModelPath(2)));

  CreateDirIfNotExists(workspace.CommunitiesDir());
  WriteReconstructionAtomically(model, workspace.CommunityModelPath(0));
  WriteTextFileAtomically("x", workspace.CommunityRecordPath(0));
  WriteReconstructionAtomically(model, workspace.CommunityOtherModelPath(0, 1));
  WriteReconstructionAtomically(model, workspace.CommunityOtherModelPath(0, 2));
  WriteReconstructionAtomically(model, workspace.CommunityModelPath(1));
  WriteTextFileAtomically("x", workspace.CommunityRecordPath(1));
  workspace.RemoveCommunity(0);
  EXPECT_FALSE(ExistsFile(workspace.CommunityRecordPath(0)));
  EXPECT_FALSE(ExistsDir(workspace.CommunityModelPath(0)));
  EXPECT_FALSE(ExistsDir(workspace.CommunityOtherModelPath(0, 1)));
  EXPECT_FALSE(ExistsDir(workspace.CommunityOtherModelPath(0, 2)));
  EXPECT_TRUE(ExistsFile(workspace.CommunityRecordPath(1)));
  EXPECT_TRUE(ExistsDir(workspace.CommunityModelPath(1)));

  WriteTextFileAtomically("plan", workspace.PlanPath());
  WriteTextFileAtomically("ini", workspace.ProjectPath());
  workspace.RemoveResults();
  EXPECT_FALSE(workspace.HasResults());
  EXPECT_FALSE(ExistsFile(workspace.PlanPath()));
  EXPECT_FALSE(ExistsDir(workspace.CommunitiesDir()));
  EXPECT_TRUE(workspace.MergedModelPaths().empty());
}

TEST(CommunityWorkspace, OutputFolderProblemsAreNamed) {
  const std::string file =
      (std::filesystem::path(CreateTestFolder()) / "a-file").string();
  std::ofstream(file) << "x";
  EXPECT_NE(CommunityWorkspace(file).CreateOutputFolder().find(
                "is a file, not a folder"),
            std::string::npos);
  EXPECT_NE(CommunityWorkspace("").CreateOutputFolder(), "");
}

}  // namespace
}  // namespace colmap
