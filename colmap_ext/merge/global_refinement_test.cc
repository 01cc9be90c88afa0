#include "colmap_ext/merge/global_refinement.h"

#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/scene/database.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// A generated scene of two clusters joined by a walkway, verified by
// COLMAP, with its correspondences and its ground truth.
struct RefinementScene {
  RefinementScene() {
    SyntheticSceneOptions scene_options;
    scene_options.num_clusters = 2;
    scene_options.num_images_per_cluster = 15;
    scene_options.num_images_per_link = 10;
    scene_options.close_loop = false;
    scene_options.keypoint_noise = 0.5;
    scene_options.seed = 12;
    const std::shared_ptr<Database> database = Database::Open(
        std::filesystem::path(CreateTestFolder()) / "database.db");
    SynthesizeCommunityScene(scene_options, &scene, database.get());
    DatabaseCache::Options cache_options;
    cache_options.min_num_matches = 15;
    database_cache = DatabaseCache::Create(*database, cache_options);
    mapper_options.num_threads = 1;
    mapper_options.random_seed = 1;
  }

  SyntheticScene scene;
  std::shared_ptr<DatabaseCache> database_cache;
  IncrementalPipelineOptions mapper_options;
};

// The merged model's adjustments stop at the tolerance given, and refine
// the intrinsics the user refines.
TEST(MergedModelRefinementOptions, StopAtTheToleranceAndRefineAsTheUser) {
  IncrementalPipelineOptions mapper_options;
  mapper_options.ba_refine_focal_length = false;
  const GlobalMapperOptions options =
      MergedModelRefinementOptions(mapper_options, /*function_tolerance=*/1e-7);
  ASSERT_TRUE(options.bundle_adjustment.ceres);
  EXPECT_EQ(options.bundle_adjustment.ceres->solver_options.function_tolerance,
            1e-7);
  EXPECT_FALSE(options.bundle_adjustment.refine_focal_length);
}

// The joined communities of a merge are each right but placed only as well
// as the averaging could: the robust adjustment and the retriangulation
// over the whole correspondence graph bring them most of the way to where
// the same refinement takes the truth itself (the keypoint noise's floor).
TEST(RefineMergedModel, BringsAPerturbedModelToTheTruth) {
  RefinementScene scene;
  const GlobalMapperOptions options =
      MergedModelRefinementOptions(scene.mapper_options,
                                   /*function_tolerance=*/1e-6);

  auto refined_truth =
      std::make_shared<Reconstruction>(scene.scene.ground_truth);
  ASSERT_TRUE(RefineMergedModel(options, scene.database_cache, refined_truth));
  const ModelEvaluation floor =
      EvaluateModel(*refined_truth, scene.scene.ground_truth);

  auto model = std::make_shared<Reconstruction>(scene.scene.ground_truth);
  PerturbReconstruction(/*max_rotation_deg=*/0.5,
                        /*translation_fraction=*/0.01,
                        /*focal_length_factor=*/1.0,
                        /*seed=*/3,
                        model.get());
  const ModelEvaluation before = EvaluateModel(*model, scene.scene.ground_truth);
  ASSERT_TRUE(RefineMergedModel(options, scene.database_cache, model));
  const ModelEvaluation after = EvaluateModel(*model, scene.scene.ground_truth);
  ASSERT_TRUE(floor.aligned);
  ASSERT_TRUE(before.aligned);
  ASSERT_TRUE(after.aligned);
  EXPECT_EQ(after.num_registered_images, before.num_registered_images);
  EXPECT_LT(after.median_position_error, 0.3 * before.median_position_error);
  EXPECT_LT(after.median_position_error, 3 * floor.median_position_error);
  EXPECT_LT(after.median_rotation_error_deg,
            0.5 * before.median_rotation_error_deg);
  EXPECT_GT(model->NumPoints3D(), 0);
}

// An image no community registered is registered as the incremental mapper
// continues the merged model; the images it could not take leave the model.
TEST(RegisterRemainingImages, RegistersWhatTheModelLacks) {
  RefinementScene scene;
  auto model = std::make_shared<Reconstruction>(scene.scene.ground_truth);
  const std::vector<image_t> reg_image_ids = model->RegImageIds();
  const image_t image_id = reg_image_ids[reg_image_ids.size() / 2];
  model->DeRegisterFrame(model->Image(image_id).FrameId());
  ASSERT_EQ(model->NumRegImages(), reg_image_ids.size() - 1);

  const int num_new = RegisterRemainingImages(
      std::make_shared<IncrementalPipelineOptions>(scene.mapper_options),
      scene.database_cache,
      model);
  EXPECT_EQ(num_new, 1);
  ASSERT_TRUE(model->ExistsImage(image_id));
  EXPECT_TRUE(model->Image(image_id).HasPose());
  const ModelEvaluation evaluation =
      EvaluateModel(*model, scene.scene.ground_truth);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_EQ(evaluation.num_registered_images, reg_image_ids.size());
  EXPECT_LT(evaluation.max_position_error, 0.01 * evaluation.extent);
}

}  // namespace
}  // namespace colmap
