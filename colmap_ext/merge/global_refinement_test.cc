#include "colmap_ext/merge/global_refinement.h"

#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/geometry/pose.h"
#include "colmap/math/math.h"
#include "colmap/scene/database.h"

#include <filesystem>
#include <set>

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
    // As the community mapper sets it.
    mapper_options.ba_global_function_tolerance = 1e-6;
  }

  SyntheticScene scene;
  std::shared_ptr<DatabaseCache> database_cache;
  IncrementalPipelineOptions mapper_options;
};

// The merged model's adjustments stop at the mapper's global tolerance,
// and refine the intrinsics the user refines.
TEST(MergedModelRefinementOptions, StopAtTheToleranceAndRefineAsTheUser) {
  IncrementalPipelineOptions mapper_options;
  mapper_options.ba_refine_focal_length = false;
  mapper_options.ba_global_function_tolerance = 1e-7;
  const GlobalMapperOptions options =
      MergedModelRefinementOptions(mapper_options);
  ASSERT_TRUE(options.bundle_adjustment.ceres);
  EXPECT_EQ(options.bundle_adjustment.ceres->solver_options.function_tolerance,
            1e-7);
  EXPECT_FALSE(options.bundle_adjustment.refine_focal_length);
}

// Whether the image belongs to the second "community": the second landmark
// with its half of the walkway.
bool InSecondCommunity(const RefinementScene& scene, const image_t image_id) {
  const int cluster = scene.scene.image_cluster.at(image_id);
  return cluster == 1 ||
         (cluster < 0 &&
          scene.scene.ground_truth.Image(image_id).ProjectionCenter().x() >= 0);
}

// The number of points observed by images of both communities.
int NumPointsAcross(const RefinementScene& scene, const Reconstruction& model) {
  int num_across = 0;
  for (const auto& [point3D_id, point3D] : model.Points3D()) {
    std::set<bool> sides;
    for (const TrackElement& element : point3D.track.Elements()) {
      sides.insert(InSecondCommunity(scene, element.image_id));
    }
    num_across += sides.size() == 2;
  }
  return num_across;
}

// A joined model as the merge has it: two communities, each right, the
// second placed only as well as the averaging could (turned by 0.15
// degrees, shifted and scaled by 0.3%), and no track crossing from one to
// the other. The retriangulation over the whole correspondence graph joins
// their tracks, and the adjustment takes the model to where the same
// refinement takes the truth itself (the keypoint noise's floor).
// (Cameras perturbed one by one, which no community's own adjustment leaves,
// are not the refinement's case.)
TEST(RefineMergedModel, JoinsTheCommunitiesTracks) {
  RefinementScene scene;

  auto refined_truth =
      std::make_shared<Reconstruction>(scene.scene.ground_truth);
  ASSERT_TRUE(RefineMergedModel(
      scene.mapper_options, scene.database_cache, refined_truth));
  const ModelEvaluation floor =
      EvaluateModel(*refined_truth, scene.scene.ground_truth);

  auto model = std::make_shared<Reconstruction>(scene.scene.ground_truth);
  std::set<image_t> second_image_ids;
  for (const image_t image_id : model->RegImageIds()) {
    if (InSecondCommunity(scene, image_id)) {
      second_image_ids.insert(image_id);
    }
  }
  // Each community with its own copy of the points, none across ...
  MoveImagesWithTheirPoints(
      second_image_ids, Eigen::Vector3d::Zero(), model.get());
  ASSERT_EQ(NumPointsAcross(scene, *model), 0);
  // ... and the second one placed a little off.
  const double extent = EvaluateModel(*model, *model).extent;
  const Sim3d offset(
      1.003,
      Eigen::Quaterniond(Eigen::AngleAxisd(
          DegToRad(0.15), Eigen::Vector3d(1, 1, 0).normalized())),
      Eigen::Vector3d(0.003 * extent, 0, 0));
  for (const image_t image_id : second_image_ids) {
    Frame& frame = model->Frame(model->Image(image_id).FrameId());
    frame.SetRigFromWorld(TransformCameraWorld(offset, frame.RigFromWorld()));
  }

  ASSERT_TRUE(
      RefineMergedModel(scene.mapper_options, scene.database_cache, model));
  const ModelEvaluation after = EvaluateModel(*model, scene.scene.ground_truth);
  ASSERT_TRUE(floor.aligned);
  ASSERT_TRUE(after.aligned);
  EXPECT_EQ(after.num_registered_images,
            scene.scene.ground_truth.NumRegImages());
  // As many tracks cross as where the truth is refined.
  EXPECT_GE(NumPointsAcross(scene, *model),
            0.8 * NumPointsAcross(scene, *refined_truth));
  EXPECT_LT(after.median_position_error, 1.5 * floor.median_position_error);
  EXPECT_LT(after.median_rotation_error_deg,
            1.5 * floor.median_rotation_error_deg);
}

// The refinement follows the user's incremental mapper: a camera held
// constant keeps its intrinsics, and the points left are within the user's
// reprojection error bound.
TEST(RefineMergedModel, FollowsTheUsersMapperOptions) {
  RefinementScene scene;
  auto model = std::make_shared<Reconstruction>(scene.scene.ground_truth);
  const camera_t camera_id = model->Cameras().begin()->first;
  // Intrinsics a little off, as a community's own adjustment leaves them.
  model->Camera(camera_id).params[0] *= 1.01;
  const std::vector<double> params = model->Camera(camera_id).params;
  scene.mapper_options.constant_cameras = {camera_id};
  scene.mapper_options.mapper.filter_max_reproj_error = 1.0;

  ASSERT_TRUE(
      RefineMergedModel(scene.mapper_options, scene.database_cache, model));
  EXPECT_EQ(model->Camera(camera_id).params, params);
  ASSERT_GT(model->NumPoints3D(), 0);
  model->UpdatePoint3DErrors();
  for (const auto& [point3D_id, point3D] : model->Points3D()) {
    EXPECT_LE(point3D.error, 1.0) << point3D_id;
  }
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
