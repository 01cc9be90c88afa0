#include "colmap_ext/merge/community_alignment.h"

#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include <filesystem>
#include <random>

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(GroupCrossEdges, GroupsEdgesBetweenCommunitiesSmallerIdFirst) {
  // Images 1-2 in community 1, 3-4 in community 0, image 5 in none.
  const ViewGraph view_graph =
      ViewGraph::Create({{1, 2}, {2, 3}, {4, 1}, {3, 4}, {4, 5}, {2, 4}},
                        {50, 50, 50, 50, 50, 10},
                        /*min_num_matches=*/15);
  const CrossEdges cross_edges =
      GroupCrossEdges(view_graph, {{1, 1}, {2, 1}, {3, 0}, {4, 0}});
  ASSERT_EQ(cross_edges.size(), 1);
  const auto& edges = cross_edges.at({0, 1});
  // Each pair with the image of community 0 first; the edge 2-4 has too few
  // matches to be in the view graph.
  ASSERT_EQ(edges.size(), 2);
  std::set<std::pair<image_t, image_t>> pairs(edges.begin(), edges.end());
  EXPECT_EQ(pairs, (std::set<std::pair<image_t, image_t>>{{3, 2}, {4, 1}}));
}

class EstimateCommunitySimilaritiesTest : public ::testing::Test {
 protected:
  void SetUp() override { Synthesize(/*num_points_per_link=*/600); }

  void Synthesize(const int num_points_per_link) {
    SyntheticSceneOptions options;
    options.num_clusters = 2;
    options.num_images_per_cluster = 14;
    options.num_images_per_link = 10;
    options.num_points_per_cluster = 1500;
    options.num_points_per_link = num_points_per_link;
    options.close_loop = false;
    options.keypoint_noise = 0.3;
    options.seed = 21;
    database_ = Database::Open(
        std::filesystem::path(CreateTestFolder()) /
        ("database" + std::to_string(num_points_per_link) + ".db"));
    scene_ = SyntheticScene();
    community_of_image_.clear();
    SynthesizeCommunityScene(options, &scene_, database_.get());
    view_graph_ = ViewGraph::Read(*database_, 15);
    // Cluster 1 is community 1; cluster 0 and the walkway, community 0.
    for (const auto& image_and_cluster : scene_.image_cluster) {
      community_of_image_[image_and_cluster.first] =
          image_and_cluster.second == 1 ? 1 : 0;
    }
    world_to_community_ = {Sim3d(0.5,
                                 Eigen::Quaterniond(Eigen::AngleAxisd(
                                     0.4, Eigen::Vector3d::UnitY())),
                                 Eigen::Vector3d(3, 0, -1)),
                           Sim3d(2.0,
                                 Eigen::Quaterniond(Eigen::AngleAxisd(
                                     -1.0, Eigen::Vector3d::UnitZ())),
                                 Eigen::Vector3d(0, 10, 0))};
  }

  // The ground truth of community c's images, in its own frame.
  std::shared_ptr<const Reconstruction> CommunityModel(const int c) const {
    return CommunityModel(c, community_of_image_);
  }

  // The same with the communities `community_of_image` assigns, every point
  // moved by normal noise of `point_noise` (drawn from `random`) before the
  // model goes to its frame (world_to_community_[c % 2]).
  std::shared_ptr<const Reconstruction> CommunityModel(
      const int c,
      const std::unordered_map<image_t, int>& community_of_image,
      const double point_noise = 0,
      std::mt19937* random = nullptr) const {
    auto model = std::make_shared<Reconstruction>(scene_.ground_truth);
    for (const image_t image_id : scene_.ground_truth.RegImageIds()) {
      if (community_of_image.at(image_id) != c) {
        model->DeRegisterFrame(model->Image(image_id).FrameId());
      }
    }
    if (point_noise > 0) {
      std::normal_distribution<double> noise(0.0, point_noise);
      for (const point3D_t point3D_id : model->Point3DIds()) {
        model->Point3D(point3D_id).xyz +=
            Eigen::Vector3d(noise(*random), noise(*random), noise(*random));
      }
    }
    model->Transform(world_to_community_[c % 2]);
    return model;
  }

  SyntheticScene scene_;
  std::shared_ptr<Database> database_;
  ViewGraph view_graph_;
  std::unordered_map<image_t, int> community_of_image_;
  std::vector<Sim3d> world_to_community_;
};

TEST_F(EstimateCommunitySimilaritiesTest, RecoversTheRelativeSimilarity) {
  const CrossEdges cross_edges =
      GroupCrossEdges(view_graph_, community_of_image_);
  ASSERT_EQ(cross_edges.size(), 1);
  const CommunitySimilarities result =
      EstimateCommunitySimilarities(*database_,
                                    view_graph_,
                                    cross_edges,
                                    {CommunityModel(0), CommunityModel(1)},
                                    PairwiseSimilarityOptions(),
                                    CovisibilityCheckOptions());
  ASSERT_EQ(result.similarities.size(), 1);
  EXPECT_TRUE(result.false_pairs.empty());
  const RelativeSimilarity& similarity = result.similarities[0];
  EXPECT_EQ(similarity.community1, 0);
  EXPECT_EQ(similarity.community2, 1);
  const Sim3d expected =
      world_to_community_[1] * Inverse(world_to_community_[0]);
  EXPECT_NEAR(similarity.second_from_first.scale(), expected.scale(), 1e-2);
  EXPECT_LT(similarity.second_from_first.rotation().angularDistance(
                expected.rotation()),
            1e-2);
  EXPECT_LT((similarity.second_from_first.translation() -
             expected.translation())
                .norm(),
            0.1);
  ASSERT_EQ(similarity.points2.size(), similarity.points1.size());
  ASSERT_GE(similarity.num_inliers,
            PairwiseSimilarityOptions().min_num_inliers);
}

TEST_F(EstimateCommunitySimilaritiesTest, PairsOfARejectedTransformAreFalse) {
  // A check no alignment can pass (twice the internal rate asked across,
  // on any number of predicted pairs) rejects the right transform: no
  // similarity is used, and the cross pairs whose matches support it are
  // false pairs, which the merged model leaves out.
  CovisibilityCheckOptions strict;
  strict.min_rate_ratio = 2.0;
  strict.min_num_predicted_pairs = 1;
  PairwiseSimilarityOptions one_hypothesis;
  one_hypothesis.max_num_hypotheses = 1;
  const CrossEdges cross_edges = GroupCrossEdges(view_graph_, community_of_image_);
  const CommunitySimilarities result = EstimateCommunitySimilarities(
      *database_,
      view_graph_,
      cross_edges,
      {CommunityModel(0), CommunityModel(1)},
      one_hypothesis,
      strict);
  EXPECT_TRUE(result.similarities.empty());
  ASSERT_EQ(cross_edges.size(), 1);
  const auto& cross_pairs = cross_edges.begin()->second;
  EXPECT_GE(result.false_pairs.size(), cross_pairs.size() / 2);
  for (const image_pair_t pair_id : result.false_pairs) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    EXPECT_EQ(community_of_image_.at(image_id1) +
                  community_of_image_.at(image_id2),
              1);
  }

  // Passed, the same transform leaves no pair false.
  const CommunitySimilarities passed = EstimateCommunitySimilarities(
      *database_,
      view_graph_,
      cross_edges,
      {CommunityModel(0), CommunityModel(1)},
      one_hypothesis,
      CovisibilityCheckOptions());
  EXPECT_EQ(passed.similarities.size(), 1);
  EXPECT_TRUE(passed.false_pairs.empty());
}

TEST_F(EstimateCommunitySimilaritiesTest, CommunityWithoutModelHasNone) {
  const CommunitySimilarities result = EstimateCommunitySimilarities(
      *database_,
      view_graph_,
      GroupCrossEdges(view_graph_, community_of_image_),
      {CommunityModel(0), nullptr},
      PairwiseSimilarityOptions(),
      CovisibilityCheckOptions());
  EXPECT_TRUE(result.similarities.empty());
}

TEST_F(EstimateCommunitySimilaritiesTest, SameResultOnAnyNumberOfThreads) {
  // Three communities (cluster 0, the walkway, cluster 1) with many points
  // between them, each model with its points moved by noise, so that
  // RANSAC's samples show in the result.
  Synthesize(/*num_points_per_link=*/4000);
  std::unordered_map<image_t, int> community_of_image;
  for (const auto& image_and_cluster : scene_.image_cluster) {
    community_of_image[image_and_cluster.first] =
        image_and_cluster.second == -1 ? 2 : image_and_cluster.second;
  }
  std::vector<std::shared_ptr<const Reconstruction>> models;
  std::mt19937 random(7);
  for (int c = 0; c < 3; ++c) {
    models.push_back(
        CommunityModel(c, community_of_image, /*point_noise=*/0.1, &random));
  }
  const CrossEdges cross_edges =
      GroupCrossEdges(view_graph_, community_of_image);
  ASSERT_GE(cross_edges.size(), 2);

  const auto estimate = [&](const int num_threads) {
    return EstimateCommunitySimilarities(*database_,
                                         view_graph_,
                                         cross_edges,
                                         models,
                                         PairwiseSimilarityOptions(),
                                         CovisibilityCheckOptions(),
                                         num_threads);
  };
  const CommunitySimilarities one_thread = estimate(1);
  const CommunitySimilarities three_threads = estimate(3);
  ASSERT_GE(one_thread.similarities.size(), 2);
  ASSERT_EQ(three_threads.similarities.size(), one_thread.similarities.size());
  EXPECT_EQ(three_threads.false_pairs, one_thread.false_pairs);
  for (size_t i = 0; i < one_thread.similarities.size(); ++i) {
    const RelativeSimilarity& a = one_thread.similarities[i];
    const RelativeSimilarity& b = three_threads.similarities[i];
    EXPECT_EQ(a.community1, b.community1);
    EXPECT_EQ(a.community2, b.community2);
    EXPECT_EQ(a.second_from_first.ToMatrix(), b.second_from_first.ToMatrix());
    EXPECT_EQ(a.points1, b.points1);
  }
}

}  // namespace
}  // namespace colmap
