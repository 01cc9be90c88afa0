#include "colmap_ext/reconstruction/community_reconstruction.h"

#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/math/random.h"
#include "colmap/scene/database.h"
#include "colmap/scene/synthetic.h"

#include <algorithm>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>

namespace colmap {
namespace {

class ReconstructCommunityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SyntheticSceneOptions options;
    options.num_clusters = 2;
    options.num_images_per_cluster = 16;
    options.num_images_per_link = 6;
    options.num_points_per_cluster = 1500;
    options.num_points_per_link = 300;
    options.close_loop = false;
    // Exact geometry: the retry below needs a scene whose landmarks the
    // mapper joins through the walkway at 15 inliers and leaves apart above
    // the walkway pairs' true correspondences.
    options.exact_two_view_geometries = true;
    options.wrong_match_fraction = 0;
    options.seed = 5;
    database_path_ =
        (std::filesystem::path(CreateTestFolder()) / "database.db").string();
    SynthesizeCommunityScene(
        options, &scene_, Database::Open(database_path_).get());
    auto mapper_options = std::make_shared<IncrementalPipelineOptions>();
    mapper_options->num_threads = 1;
    for (const auto& [image_id, cluster] : scene_.image_cluster) {
      if (cluster == 0) {
        mapper_options->image_names.push_back(
            scene_.ground_truth.Image(image_id).Name());
      }
    }
    options_ = mapper_options;
  }

  bool IsCommunityImage(const std::string& name) const {
    return std::find(options_->image_names.begin(),
                     options_->image_names.end(),
                     name) != options_->image_names.end();
  }

  SyntheticScene scene_;
  std::string database_path_;
  std::shared_ptr<const IncrementalPipelineOptions> options_;
};

TEST_F(ReconstructCommunityTest, ReconstructsOnlyTheCommunitysImages) {
  std::mutex database_mutex;
  const CommunityReconstruction result =
      ReconstructCommunityModels(options_, "", database_path_, &database_mutex);
  ASSERT_TRUE(result.model);
  EXPECT_GE(result.num_models, 1);
  EXPECT_EQ(result.other_models.size() + 1, result.num_models);
  EXPECT_EQ(result.model->NumRegImages(), options_->image_names.size());
  for (const image_t image_id : result.model->RegImageIds()) {
    EXPECT_TRUE(IsCommunityImage(result.model->Image(image_id).Name()));
  }
}

// The same community gives the same model whichever thread reconstructs it
// and whatever that thread did before: what lets a cluster's jobs replace
// the built-in workers.
TEST_F(ReconstructCommunityTest, SameModelInAnyThread) {
  std::mutex database_mutex;
  const CommunityReconstruction first =
      ReconstructCommunityModels(options_, "", database_path_, &database_mutex);
  CommunityReconstruction second;
  std::thread thread([&] {
    // Draw from this thread's random number generator first.
    RandomUniformInteger<int>(0, 100);
    second =
        ReconstructCommunityModels(options_, "", database_path_, &database_mutex);
  });
  thread.join();
  ASSERT_TRUE(first.model && second.model);
  ASSERT_EQ(first.model->NumRegImages(), second.model->NumRegImages());
  for (const image_t image_id : first.model->RegImageIds()) {
    const Image& image1 = first.model->Image(image_id);
    const Image& image2 = second.model->Image(image_id);
    EXPECT_LT((image1.ProjectionCenter() - image2.ProjectionCenter()).norm(),
              1e-9);
  }
}

// Two landmarks without the walkway that joins them: the mapper makes a
// model of each, and both are returned, the largest as the community's.
TEST_F(ReconstructCommunityTest, OtherModelsAreKeptLargestFirst) {
  auto options = std::make_shared<IncrementalPipelineOptions>(*options_);
  options->image_names.clear();
  int num_dropped = 0;
  for (const auto& [image_id, cluster] : scene_.image_cluster) {
    const std::string& name = scene_.ground_truth.Image(image_id).Name();
    // Cluster 1 without three of its images: the smaller model.
    if (cluster == 0 || (cluster == 1 && ++num_dropped > 3)) {
      options->image_names.push_back(name);
    }
  }
  std::mutex database_mutex;
  const CommunityReconstruction result =
      ReconstructCommunityModels(options, "", database_path_, &database_mutex);
  ASSERT_TRUE(result.model);
  EXPECT_EQ(result.num_models, 2);
  ASSERT_EQ(result.other_models.size(), 1);
  EXPECT_EQ(result.model->NumRegImages(), 16);
  EXPECT_EQ(result.other_models[0]->NumRegImages(), 13);
  for (const image_t image_id : result.other_models[0]->RegImageIds()) {
    EXPECT_EQ(scene_.image_cluster.at(image_id), 1);
  }
}

TEST_F(ReconstructCommunityTest, NoImagesWithMatchesGivesNoModel) {
  auto options = std::make_shared<IncrementalPipelineOptions>(*options_);
  options->image_names = {"no-such-image.jpg"};
  std::mutex database_mutex;
  const CommunityReconstruction result =
      ReconstructCommunityModels(options, "", database_path_, &database_mutex);
  EXPECT_FALSE(result.model);
  EXPECT_EQ(result.num_models, 0);
}

// A model of six images, and the same six with two more in a second model.
TEST(RoomForAnotherModel, CountsTheImagesNoModelRegisters) {
  SyntheticDatasetOptions options;
  options.num_rigs = 1;
  options.num_frames_per_rig = 8;
  options.num_points3D = 50;
  Reconstruction eight;
  SynthesizeDataset(options, &eight);
  Reconstruction six = eight;
  for (const frame_t frame_id : {1, 2}) {
    six.DeRegisterFrame(frame_id);
  }
  ASSERT_EQ(six.NumRegImages(), 6);

  ReconstructionManager models;
  *models.Get(models.Add()) = six;
  EXPECT_TRUE(RoomForAnotherModel(models, /*num_images=*/16, 10));
  EXPECT_FALSE(RoomForAnotherModel(models, /*num_images=*/15, 10));
  EXPECT_TRUE(RoomForAnotherModel(models, /*num_images=*/6, 0));

  // The images registered in both models count once.
  *models.Get(models.Add()) = eight;
  EXPECT_TRUE(RoomForAnotherModel(models, /*num_images=*/18, 10));
  EXPECT_FALSE(RoomForAnotherModel(models, /*num_images=*/17, 10));
}

}  // namespace
}  // namespace colmap
