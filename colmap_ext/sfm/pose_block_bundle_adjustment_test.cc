#include "colmap_ext/sfm/pose_block_bundle_adjustment.h"

#include "colmap_ext/scene/model_evaluation.h"
#include "colmap_ext/scene/synthetic_scene.h"

#include "colmap/math/random.h"
#include "colmap/scene/synthetic.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

// COLMAP's synthetic scene (noisy keypoints, two cameras) with every camera
// and point moved by a fraction of the extent of the camera centres.
Reconstruction PerturbedScene() {
  SetPRNGSeed(5);
  SyntheticDatasetOptions options;
  options.num_cameras = 2;
  options.num_images = 12;
  options.num_points3D = 1000;
  options.point2D_stddev = 0.5;
  Reconstruction model;
  SynthesizeDataset(options, &model);
  PerturbReconstruction(/*max_rotation_deg=*/1,
                        /*translation_fraction=*/0.01,
                        /*focal_length_factor=*/1.01,
                        /*seed=*/6,
                        &model);
  return model;
}

BundleAdjustmentOptions ConvergingOptions() {
  BundleAdjustmentOptions options;
  options.print_summary = false;
  options.solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  options.solver_options.function_tolerance = 1e-12;
  options.solver_options.gradient_tolerance = 1e-14;
  options.solver_options.parameter_tolerance = 1e-14;
  options.solver_options.max_num_iterations = 200;
  options.solver_options.num_threads = 1;
  return options;
}

// Solves `config` from the same start with COLMAP's BundleAdjuster and with
// PoseBlockBundleAdjuster, and expects the same cost, poses, intrinsics and
// points: one block per pose changes how Ceres solves, not what.
void ExpectSameSolutionAsColmap(const BundleAdjustmentOptions& options,
                                const BundleAdjustmentConfig& config,
                                const Reconstruction& start) {
  Reconstruction colmap_model = start;
  BundleAdjuster colmap_adjuster(options, config);
  ASSERT_TRUE(colmap_adjuster.Solve(&colmap_model));
  const ceres::Solver::Summary& colmap_summary = colmap_adjuster.Summary();
  ASSERT_TRUE(colmap_summary.IsSolutionUsable());

  Reconstruction model = start;
  PoseBlockBundleAdjuster adjuster(options, config);
  adjuster.SetUpProblem(&model);
  EXPECT_EQ(adjuster.Problem().NumResiduals(), colmap_summary.num_residuals);
  const ceres::Solver::Summary summary =
      adjuster.Solve(options.solver_options, &model);
  ASSERT_TRUE(summary.IsSolutionUsable());
  EXPECT_LT(summary.final_cost, summary.initial_cost);
  EXPECT_NEAR(summary.final_cost,
              colmap_summary.final_cost,
              1e-9 * colmap_summary.final_cost);

  const double extent = EvaluateModel(start, start).extent;
  for (const image_t image_id : model.RegImageIds()) {
    const Rigid3d& ours = model.Image(image_id).CamFromWorld();
    const Rigid3d& colmaps = colmap_model.Image(image_id).CamFromWorld();
    EXPECT_LT(ours.rotation.angularDistance(colmaps.rotation), 1e-7);
    EXPECT_LT((ours.translation - colmaps.translation).norm(), 1e-7 * extent);
  }
  for (const auto& camera : model.Cameras()) {
    const std::vector<double>& colmaps =
        colmap_model.Camera(camera.first).params;
    for (size_t k = 0; k < colmaps.size(); ++k) {
      EXPECT_NEAR(camera.second.params[k],
                  colmaps[k],
                  1e-6 * std::max(1.0, std::abs(colmaps[k])));
    }
  }
  for (const auto& point3D : model.Points3D()) {
    EXPECT_LT(
        (point3D.second.xyz - colmap_model.Point3D(point3D.first).xyz).norm(),
        1e-6 * extent);
  }
}

TEST(PoseBlockBundleAdjuster, SolvesTheMappersGlobalAdjustmentAsColmapDoes) {
  const Reconstruction start = PerturbedScene();
  ExpectSameSolutionAsColmap(ConvergingOptions(), MappersGauge(start), start);
}

TEST(PoseBlockBundleAdjuster, HoldsWhatTheConfigurationAndOptionsHold) {
  const Reconstruction start = PerturbedScene();
  const std::vector<image_t> image_ids = start.RegImageIds();
  // Two images left out (every point is seen by every image, so every
  // point is then held), two poses held (as
  // the mapper's fix_existing_images), a position held in two coordinates,
  // one camera's intrinsics held, the other's focal length alone refined.
  BundleAdjustmentConfig config;
  for (size_t k = 2; k < image_ids.size(); ++k) {
    config.AddImage(image_ids[k]);
  }
  config.SetConstantCamPose(image_ids[2]);
  config.SetConstantCamPose(image_ids[3]);
  config.SetConstantCamPositions(image_ids[4], {0, 2});
  const camera_t held_camera = start.Image(image_ids[5]).CameraId();
  config.SetConstantCamIntrinsics(held_camera);
  BundleAdjustmentOptions options = ConvergingOptions();
  options.refine_extra_params = false;
  ExpectSameSolutionAsColmap(options, config, start);

  Reconstruction model = start;
  PoseBlockBundleAdjuster adjuster(options, config);
  adjuster.SetUpProblem(&model);
  adjuster.Solve(options.solver_options, &model);
  for (const image_t image_id : {image_ids[0], image_ids[1], image_ids[2]}) {
    EXPECT_EQ(model.Image(image_id).CamFromWorld().translation,
              start.Image(image_id).CamFromWorld().translation);
  }
  EXPECT_EQ(model.Image(image_ids[4]).CamFromWorld().translation.x(),
            start.Image(image_ids[4]).CamFromWorld().translation.x());
  EXPECT_EQ(model.Image(image_ids[4]).CamFromWorld().translation.z(),
            start.Image(image_ids[4]).CamFromWorld().translation.z());
  EXPECT_NE(model.Image(image_ids[4]).CamFromWorld().translation.y(),
            start.Image(image_ids[4]).CamFromWorld().translation.y());
  EXPECT_EQ(model.Camera(held_camera).params, start.Camera(held_camera).params);
  for (const auto& camera : model.Cameras()) {
    if (camera.first != held_camera) {
      EXPECT_NE(camera.second.params[0], start.Camera(camera.first).params[0]);
      EXPECT_EQ(camera.second.params.back(),
                start.Camera(camera.first).params.back());
    }
  }
}

TEST(PoseBlockBundleAdjuster, AdjustsOnTheGivenPointsOnly) {
  Reconstruction model = PerturbedScene();
  const Reconstruction start = model;
  const BundleAdjustmentConfig config = MappersGauge(model);
  std::unordered_set<point3D_t> selected;
  size_t num_observations = 0;
  for (const auto& point3D : model.Points3D()) {
    if (point3D.first % 4 == 0) {
      selected.insert(point3D.first);
      num_observations += point3D.second.track.Length();
    }
  }
  const BundleAdjustmentOptions options = ConvergingOptions();
  PoseBlockBundleAdjuster adjuster(options, config);
  adjuster.SetUpProblem(&model, &selected);
  EXPECT_EQ(adjuster.Problem().NumResiduals(), 2 * num_observations);
  EXPECT_TRUE(
      adjuster.Solve(options.solver_options, &model).IsSolutionUsable());
  for (const auto& point3D : model.Points3D()) {
    if (selected.count(point3D.first) == 0) {
      EXPECT_EQ(point3D.second.xyz, start.Point3D(point3D.first).xyz);
    } else {
      EXPECT_NE(point3D.second.xyz, start.Point3D(point3D.first).xyz);
    }
  }
}

TEST(AdjustGlobalBundleWithPoseBlocks, AdjustsOrSaysThereWasNothingToAdjust) {
  Reconstruction model = PerturbedScene();
  const BundleAdjustmentConfig config = MappersGauge(model);
  model.UpdatePoint3DErrors();
  const double error_before = model.ComputeMeanReprojectionError();
  EXPECT_TRUE(
      AdjustGlobalBundleWithPoseBlocks(ConvergingOptions(), config, &model));
  model.UpdatePoint3DErrors();
  EXPECT_LT(model.ComputeMeanReprojectionError(), 0.5 * error_before);

  // Images that observe no point: nothing to adjust.
  Reconstruction empty = model;
  for (const point3D_t point3D_id : empty.Point3DIds()) {
    empty.DeletePoint3D(point3D_id);
  }
  EXPECT_FALSE(
      AdjustGlobalBundleWithPoseBlocks(ConvergingOptions(), config, &empty));

  // Configured points are not what it takes.
  BundleAdjustmentConfig with_points = config;
  with_points.AddVariablePoint(*model.Point3DIds().begin());
  EXPECT_THROW(PoseBlockBundleAdjuster(ConvergingOptions(), with_points),
               std::exception);
}

}  // namespace
}  // namespace colmap
