#include "colmap_ext/merge/community_merger.h"

#include "colmap_ext/partition/community_detection.h"
#include "colmap_ext/partition/view_graph.h"
#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/geometry/pose.h"
#include "colmap/scene/database.h"
#include "colmap/util/file.h"

#include <filesystem>
#include <set>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// The merge stage on community models cut from a generated loop's ground
// truth, each in a frame of its own, as their stage would leave them in a
// workspace: the plan from the view graph's communities, every community's
// model (its own and borrowed images) and record.
class MergeCommunitiesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::filesystem::path test_dir = CreateTestFolder();
    SyntheticSceneOptions scene_options;
    scene_options.num_clusters = 3;
    scene_options.num_images_per_cluster = 24;
    scene_options.num_images_per_link = 20;
    scene_options.seed = 17;
    options_.database_path = (test_dir / "database.db").string();
    const std::shared_ptr<Database> database =
        Database::Open(options_.database_path);
    SynthesizeCommunityScene(scene_options, &scene_, database.get());
    options_.incremental_options.num_threads = 1;
    workspace_ =
        std::make_unique<CommunityWorkspace>((test_dir / "out").string());
    CreateDirIfNotExists(workspace_->CommunitiesDir(), /*recursive=*/true);

    const ViewGraph view_graph =
        ViewGraph::Read(*database, options_.min_num_matches);
    const WeightedGraph graph =
        view_graph.ToWeightedGraph(ViewGraphEdgeWeight::kUnit);
    const CommunityPartition partition = DetectCommunities(
        graph, GreedyModularityPartitioner(), CommunityDetectionOptions());
    ASSERT_GE(partition.NumCommunities(), 3);
    const std::vector<std::vector<int>> extended =
        ExtendCommunities(graph, partition, /*num_overlap_images=*/3);
    plan_.communities.resize(partition.NumCommunities());
    community_images_.resize(partition.NumCommunities());
    for (int c = 0; c < partition.NumCommunities(); ++c) {
      for (const int vertex : extended[c]) {
        const std::string& name = view_graph.ImageNames()[vertex];
        (partition.membership[vertex] == c
             ? plan_.communities[c].own_image_names
             : plan_.communities[c].borrowed_image_names)
            .push_back(name);
        community_images_[c].insert(view_graph.ImageIds()[vertex]);
      }
    }
  }

  // Writes community c's model, cut from the ground truth and placed by
  // `model_from_world`, and its record (its mean reprojection error
  // `reprojection_error`, as its mapper would report it); its cameras and
  // points moved by up to `perturbation_deg` if given.
  void WriteCommunity(const int c,
                      const Sim3d& model_from_world,
                      const double reprojection_error,
                      const double perturbation_deg = 0) {
    Reconstruction model = CommunityModel(
        scene_.ground_truth, community_images_[c], model_from_world);
    if (perturbation_deg > 0) {
      PerturbReconstruction(perturbation_deg,
                            /*translation_fraction=*/1e-4,
                            /*focal_length_factor=*/1.0,
                            /*seed=*/c + 1,
                            &model);
    }
    WriteReconstructionAtomically(model, workspace_->CommunityModelPath(c));
    CommunityRecord record;
    record.community_id = c;
    record.num_images = static_cast<int>(community_images_[c].size());
    record.num_registered = static_cast<int>(model.NumRegImages());
    record.num_points = static_cast<int>(model.NumPoints3D());
    record.num_models = 1;
    record.mean_reprojection_error = reprojection_error;
    WriteTextFileAtomically(CommunityRecordToText(record),
                            workspace_->CommunityRecordPath(c));
  }

  // A similarity of its own for community c.
  static Sim3d FrameOf(const int c) {
    return Sim3d(0.5 + c,
                 Eigen::Quaterniond(Eigen::AngleAxisd(
                     0.4 * (c + 1), Eigen::Vector3d(1, 2, 3).normalized())),
                 Eigen::Vector3d(10.0 * c, -5.0, 2.0 * c));
  }

  CommunityMergerResult Merge() const {
    CommunityMerger merger(options_, plan_, *workspace_);
    merger.Solve();
    return merger.Result();
  }

  SyntheticScene scene_;
  CommunityMergerOptions options_;
  CommunityPlan plan_;
  std::vector<std::set<image_t>> community_images_;
  std::unique_ptr<CommunityWorkspace> workspace_;
};

TEST_F(MergeCommunitiesTest, CommunitiesInFramesOfTheirOwnMergeIntoOneModel) {
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    WriteCommunity(c, FrameOf(c), /*reprojection_error=*/0.5);
  }
  const CommunityMergerResult result = Merge();
  ASSERT_EQ(result.models.size(), 1);
  EXPECT_EQ(result.models[0]->NumRegImages(),
            scene_.ground_truth.NumRegImages());
  EXPECT_EQ(result.num_kept_similarities, result.num_estimated_similarities);
  EXPECT_GE(result.num_kept_similarities, plan_.NumCommunities());
  const ModelEvaluation evaluation =
      EvaluateModel(*result.models[0], scene_.ground_truth);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_LT(evaluation.median_position_error, 1e-3 * evaluation.extent);
  EXPECT_LT(evaluation.median_rotation_error_deg, 0.2);
}

// A community is judged by its links, not by its own model's statistics:
// one whose mapper reports a reprojection error far above the others' but
// whose links agree with the rest takes part whole, at its place.
TEST_F(MergeCommunitiesTest, CommunityWithLargeOwnErrorsStaysWhole) {
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    WriteCommunity(c, FrameOf(c), /*reprojection_error=*/c == 1 ? 5.0 : 0.5);
  }
  const CommunityMergerResult result = Merge();
  EXPECT_EQ(result.num_kept_similarities, result.num_estimated_similarities);
  ASSERT_EQ(result.models.size(), 1);
  EXPECT_EQ(result.models[0]->NumRegImages(),
            scene_.ground_truth.NumRegImages());
  const ModelEvaluation evaluation =
      EvaluateModel(*result.models[0], scene_.ground_truth);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_LT(evaluation.median_position_error, 1e-3 * evaluation.extent);
}

// Communities that share no kept similarity are written as models apart,
// no image in two of them.
TEST_F(MergeCommunitiesTest, PartsWithoutALinkStayApart) {
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    WriteCommunity(c, FrameOf(c), /*reprojection_error=*/0.5);
  }
  // No similarity has enough inliers.
  options_.pairwise_similarity.min_num_inliers = 1000000;
  options_.skip_registration = true;
  const CommunityMergerResult result = Merge();
  EXPECT_EQ(result.num_kept_similarities, 0);
  ASSERT_EQ(result.models.size(), plan_.NumCommunities());
  std::set<image_t> seen;
  for (const auto& model : result.models) {
    for (const image_t image_id : model->RegImageIds()) {
      EXPECT_TRUE(seen.insert(image_id).second) << image_id;
    }
  }
}

}  // namespace
}  // namespace colmap

namespace colmap {
namespace {

// Parts that no similarity joins are offered to the largest part, whose
// registration (stage 4) registers their images: one model of every image,
// as colmap mapper would make; without the stage, a model per part.
TEST_F(MergeCommunitiesTest, RegistrationJoinsPartsWithoutALink) {
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    WriteCommunity(c, FrameOf(c), /*reprojection_error=*/0.5);
  }
  options_.pairwise_similarity.min_num_inliers = 1000000;
  const CommunityMergerResult result = Merge();
  EXPECT_EQ(result.num_kept_similarities, 0);
  ASSERT_EQ(result.models.size(), 1);
  EXPECT_EQ(result.models[0]->NumRegImages(),
            scene_.ground_truth.NumRegImages());
  const ModelEvaluation evaluation =
      EvaluateModel(*result.models[0], scene_.ground_truth);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_LT(evaluation.median_position_error, 1e-2 * evaluation.extent);

  options_.skip_registration = true;
  EXPECT_EQ(Merge().models.size(), plan_.NumCommunities());
}

// Communities each a little off (as a mapper leaves them) are joined within
// the averaging's bound; the global refinement (stage 3) brings the merged
// model closer to the truth than the join alone.
TEST_F(MergeCommunitiesTest, GlobalRefinementBringsTheJoinedModelCloser) {
  for (int c = 0; c < plan_.NumCommunities(); ++c) {
    WriteCommunity(c,
                   FrameOf(c),
                   /*reprojection_error=*/0.5,
                   /*perturbation_deg=*/0.3);
  }
  options_.skip_registration = true;
  const CommunityMergerResult refined = Merge();
  options_.skip_global_refinement = true;
  const CommunityMergerResult joined = Merge();
  ASSERT_EQ(refined.models.size(), 1);
  ASSERT_EQ(joined.models.size(), 1);
  const ModelEvaluation refined_evaluation =
      EvaluateModel(*refined.models[0], scene_.ground_truth);
  const ModelEvaluation joined_evaluation =
      EvaluateModel(*joined.models[0], scene_.ground_truth);
  ASSERT_TRUE(refined_evaluation.aligned);
  ASSERT_TRUE(joined_evaluation.aligned);
  EXPECT_LT(refined_evaluation.median_position_error,
            0.5 * joined_evaluation.median_position_error);
  EXPECT_LT(refined_evaluation.median_rotation_error_deg,
            0.5 * joined_evaluation.median_rotation_error_deg);
}

}  // namespace
}  // namespace colmap
