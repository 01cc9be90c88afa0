#include "colmap_ext/sfm/reduced_bundle_adjustment.h"

#include "colmap_ext/scene/model_evaluation.h"
#include "colmap_ext/scene/synthetic_scene.h"

#include "colmap/math/random.h"
#include "colmap/scene/synthetic.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// A generated loop of landmark clusters (long and short tracks, noisy
// keypoints) with the reprojection errors of its true points.
Reconstruction GroundTruth() {
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 12;
  options.num_images_per_link = 8;
  options.num_points_per_cluster = 1500;
  options.num_points_per_link = 600;
  options.keypoint_noise = 0.5;
  options.seed = 4;
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, /*database=*/nullptr);
  scene.ground_truth.UpdatePoint3DErrors();
  return scene.ground_truth;
}

// COLMAP's synthetic scene (every point seen by every image), noisy
// keypoints, well conditioned: what a bundle adjustment converges to is
// close to the truth. One rig of `num_cameras` cameras.
Reconstruction WellConditionedGroundTruth(const int num_cameras = 1) {
  SetPRNGSeed(3);
  SyntheticDatasetOptions options;
  options.num_rigs = 1;
  options.num_cameras_per_rig = num_cameras;
  options.num_frames_per_rig = 15;
  options.num_points3D = 2000;
  Reconstruction ground_truth;
  SynthesizeDataset(options, &ground_truth);
  SyntheticNoiseOptions noise_options;
  noise_options.point2D_stddev = 0.5;
  SynthesizeNoise(noise_options, &ground_truth);
  ground_truth.UpdatePoint3DErrors();
  return ground_truth;
}

// The ground truth with every camera and point moved by a fraction of the
// extent of the camera centres.
Reconstruction Perturbed(const Reconstruction& ground_truth) {
  Reconstruction model = ground_truth;
  PerturbReconstruction(/*max_rotation_deg=*/1,
                        /*translation_fraction=*/0.01,
                        /*focal_length_factor=*/1,
                        /*seed=*/7,
                        &model);
  model.UpdatePoint3DErrors();
  return model;
}

BundleAdjustmentOptions AdjustmentOptions() {
  BundleAdjustmentOptions options;
  options.print_summary = false;
  options.ceres->solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  options.ceres->solver_options.function_tolerance = 1e-8;
  return options;
}

TEST(SelectBundleTracks, CoversEveryImageWithFewerTracks) {
  const Reconstruction ground_truth = GroundTruth();
  TrackSelectionOptions options;
  options.grid_size = 6;
  options.min_tracks_per_image = 60;
  const std::unordered_set<point3D_t> selected =
      SelectBundleTracks(options, ground_truth);
  EXPECT_LT(selected.size(), ground_truth.NumPoints3D() / 2);
  for (const image_t image_id : ground_truth.RegImageIds()) {
    const Image& image = ground_truth.Image(image_id);
    const Camera& camera = ground_truth.Camera(image.CameraId());
    std::set<int> observed_cells;
    std::set<int> selected_cells;
    int num_observed = 0;
    int num_selected = 0;
    for (const Point2D& point2D : image.Points2D()) {
      if (!point2D.HasPoint3D()) continue;
      const int cell =
          std::min(5, static_cast<int>(6 * point2D.xy.y() / camera.height)) *
              6 +
          std::min(5, static_cast<int>(6 * point2D.xy.x() / camera.width));
      ++num_observed;
      observed_cells.insert(cell);
      if (selected.count(point2D.point3D_id)) {
        ++num_selected;
        selected_cells.insert(cell);
      }
    }
    // Every cell the image has points in holds a selected one, and every
    // image keeps its minimum.
    EXPECT_EQ(selected_cells, observed_cells) << image.Name();
    EXPECT_GE(num_selected, std::min(num_observed, 60)) << image.Name();
  }
}

TEST(SelectBundleTracks, PrefersLongThenAccurateTracks) {
  Reconstruction model = GroundTruth();
  TrackSelectionOptions options;
  options.grid_size = 1;  // One cell: one track per image at most ...
  options.min_tracks_per_image = 0;  // ... and nothing added.
  options.long_track_length = 1000;
  std::unordered_set<point3D_t> selected = SelectBundleTracks(options, model);
  EXPECT_LE(selected.size(), model.NumRegImages());
  // The first image chooses first: the longest track it observes.
  const image_t image_id = model.RegImageIds()[0];
  size_t longest = 0;
  size_t longest_selected = 0;
  for (const Point2D& point2D : model.Image(image_id).Points2D()) {
    if (!point2D.HasPoint3D()) continue;
    const size_t length = model.Point3D(point2D.point3D_id).track.Length();
    longest = std::max(longest, length);
    if (selected.count(point2D.point3D_id)) {
      longest_selected = std::max(longest_selected, length);
    }
  }
  EXPECT_EQ(longest_selected, longest);
  // Every later image chooses only if no track chosen before covers it.
  for (const image_t other_image_id : model.RegImageIds()) {
    int num_observed_selected = 0;
    for (const Point2D& point2D : model.Image(other_image_id).Points2D()) {
      num_observed_selected +=
          point2D.HasPoint3D() && selected.count(point2D.point3D_id);
    }
    EXPECT_GE(num_observed_selected, 1);
  }

  // Among tracks at least `long_track_length` long, the accurate one wins.
  options.long_track_length = 2;
  point3D_t accurate = kInvalidPoint3DId;
  for (const Point2D& point2D : model.Image(image_id).Points2D()) {
    if (point2D.HasPoint3D()) {
      accurate = point2D.point3D_id;
    }
  }
  ASSERT_NE(accurate, kInvalidPoint3DId);
  for (const point3D_t point3D_id : model.Point3DIds()) {
    model.Point3D(point3D_id).error = point3D_id == accurate ? 0.0 : 1.0;
  }
  selected = SelectBundleTracks(options, model);
  EXPECT_EQ(selected.count(accurate), 1);
}

TEST(AdjustCamerasOnTracks, CamerasAsAccurateAsTheFullAdjustment) {
  const Reconstruction ground_truth = WellConditionedGroundTruth();
  const BundleAdjustmentOptions ba_options = AdjustmentOptions();

  Reconstruction full = Perturbed(ground_truth);
  const double perturbed_error =
      EvaluateModel(full, ground_truth).median_position_error;
  ASSERT_TRUE(
      AdjustAllObservations(ba_options, ba_options.ceres->solver_options, &full)
          .IsSolutionUsable());
  const ModelEvaluation full_evaluation = EvaluateModel(full, ground_truth);

  Reconstruction reduced = Perturbed(ground_truth);
  const TrackSelectionOptions selection;
  const std::unordered_set<point3D_t> selected =
      SelectBundleTracks(selection, reduced);
  ASSERT_LT(selected.size(), reduced.NumPoints3D() / 2);
  ASSERT_TRUE(AdjustCamerasOnTracks(
      ba_options, ba_options.ceres->solver_options, selected, &reduced));
  EXPECT_EQ(RefinePointsWithFixedCameras(ba_options,
                                         selected,
                                         /*max_points_per_problem=*/500,
                                         &reduced),
            reduced.NumPoints3D() - selected.size());
  const ModelEvaluation reduced_evaluation =
      EvaluateModel(reduced, ground_truth);
  LOG(INFO) << "Median position error: perturbed " << perturbed_error
            << ", full adjustment " << full_evaluation.median_position_error
            << ", on " << selected.size() << " of " << reduced.NumPoints3D()
            << " tracks " << reduced_evaluation.median_position_error;
  EXPECT_LT(full_evaluation.median_position_error, 0.1 * perturbed_error);
  // The perturbation is undone; the cameras are less precise than after the
  // full adjustment, as the noise averages over fewer observations (by
  // about the square root of their ratio).
  EXPECT_LT(reduced_evaluation.median_position_error, 0.1 * perturbed_error);
  const double noise_ratio = std::sqrt(
      static_cast<double>(ground_truth.NumPoints3D()) / selected.size());
  EXPECT_LT(reduced_evaluation.median_position_error,
            1.5 * noise_ratio * full_evaluation.median_position_error);
  EXPECT_LT(reduced_evaluation.median_rotation_error_deg,
            1.5 * noise_ratio * full_evaluation.median_rotation_error_deg);
  // Every point, selected or not, fits the adjusted cameras about as well
  // as after the full adjustment.
  reduced.UpdatePoint3DErrors();
  full.UpdatePoint3DErrors();
  EXPECT_LT(reduced.ComputeMeanReprojectionError(),
            1.1 * full.ComputeMeanReprojectionError());
}

TEST(AdjustAllObservations, UndoesAPerturbationWithTheMappersGauge) {
  const Reconstruction ground_truth = WellConditionedGroundTruth();
  const BundleAdjustmentOptions ba_options = AdjustmentOptions();
  Reconstruction model = Perturbed(ground_truth);
  const double perturbed_error =
      EvaluateModel(model, ground_truth).median_position_error;
  // COLMAP's mapper's gauge: the pose of the image of smallest id, and the
  // coordinate of the next one's position along which the two are furthest
  // apart.
  std::vector<image_t> image_ids = model.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  const image_t first = image_ids[0];
  const image_t second = image_ids[1];
  const Rigid3d first_pose = model.Image(first).CamFromWorld();
  const Eigen::Vector3d baseline =
      (first_pose * Inverse(model.Image(second).CamFromWorld())).translation();
  Eigen::Index fixed_dim = 0;
  ASSERT_GT(baseline.cwiseAbs().maxCoeff(&fixed_dim), 1e-9);
  const double second_coordinate =
      model.Image(second).CamFromWorld().translation()(fixed_dim);

  const ceres::Solver::Summary summary = AdjustAllObservations(
      ba_options, ba_options.ceres->solver_options, &model);
  ASSERT_TRUE(summary.IsSolutionUsable());
  EXPECT_LT(summary.final_cost, 0.01 * summary.initial_cost);
  size_t num_observations = 0;
  for (const auto& point3D : model.Points3D()) {
    num_observations += point3D.second.track.Length();
  }
  EXPECT_EQ(summary.num_residuals, 2 * static_cast<int>(num_observations));
  EXPECT_LT(EvaluateModel(model, ground_truth).median_position_error,
            0.1 * perturbed_error);
  // The gauge: the first image's pose (its quaternion normalized by the
  // adjuster) and one coordinate of the second's translation stay where they
  // were.
  const Rigid3d first_pose_after = model.Image(first).CamFromWorld();
  EXPECT_LT(first_pose_after.rotation().angularDistance(first_pose.rotation()),
            1e-12);
  EXPECT_EQ(Eigen::Vector3d(first_pose_after.translation()),
            Eigen::Vector3d(first_pose.translation()));
  EXPECT_EQ(model.Image(second).CamFromWorld().translation()(fixed_dim),
            second_coordinate);

  // Nothing to adjust: no iteration, not usable.
  Reconstruction single = model;
  const std::vector<frame_t> reg_frame_ids = single.RegFrameIds();
  for (const frame_t frame_id : reg_frame_ids) {
    if (frame_id != single.Image(first).FrameId()) {
      single.DeRegisterFrame(frame_id);
    }
  }
  ASSERT_EQ(single.NumRegImages(), 1);
  const ceres::Solver::Summary nothing = AdjustAllObservations(
      ba_options, ba_options.ceres->solver_options, &single);
  EXPECT_FALSE(nothing.IsSolutionUsable());
  EXPECT_TRUE(nothing.iterations.empty());
}

TEST(AdjustAllObservations, HoldsTheConstantCameras) {
  const Reconstruction ground_truth = WellConditionedGroundTruth();
  BundleAdjustmentOptions ba_options = AdjustmentOptions();
  ba_options.refine_focal_length = true;
  Reconstruction model = Perturbed(ground_truth);
  const camera_t camera_id = model.Cameras().begin()->first;
  model.Camera(camera_id).SetFocalLength(
      1.1 * model.Camera(camera_id).MeanFocalLength());
  const std::vector<double> params = model.Camera(camera_id).params;

  Reconstruction held = model;
  ASSERT_TRUE(AdjustAllObservations(ba_options,
                                    ba_options.ceres->solver_options,
                                    &held,
                                    /*constant_cameras=*/{camera_id})
                  .IsSolutionUsable());
  EXPECT_EQ(held.Camera(camera_id).params, params);
  const TrackSelectionOptions selection;
  Reconstruction held_on_tracks = model;
  ASSERT_TRUE(AdjustCamerasOnTracks(ba_options,
                                    ba_options.ceres->solver_options,
                                    SelectBundleTracks(selection, model),
                                    &held_on_tracks,
                                    /*constant_cameras=*/{camera_id}));
  EXPECT_EQ(held_on_tracks.Camera(camera_id).params, params);

  // Not held, the focal length goes back towards the truth.
  ASSERT_TRUE(AdjustAllObservations(
                  ba_options, ba_options.ceres->solver_options, &model)
                  .IsSolutionUsable());
  const double true_focal_length =
      ground_truth.Camera(camera_id).MeanFocalLength();
  EXPECT_LT(
      std::abs(model.Camera(camera_id).MeanFocalLength() - true_focal_length),
      0.01 * true_focal_length);
}

TEST(AdjustAllObservations, HoldsTheConstantRigs) {
  // A two-camera rig whose second camera is placed a fifth of the baseline
  // off.
  const Reconstruction ground_truth =
      WellConditionedGroundTruth(/*num_cameras=*/2);
  const rig_t rig_id = ground_truth.Rigs().begin()->first;
  ASSERT_EQ(ground_truth.Rig(rig_id).NonRefSensors().size(), 1);
  const sensor_t sensor_id =
      ground_truth.Rig(rig_id).NonRefSensors().begin()->first;
  const Rigid3d true_sensor_from_rig =
      ground_truth.Rig(rig_id).SensorFromRig(sensor_id);
  const double baseline = true_sensor_from_rig.translation().norm();
  ASSERT_GT(baseline, 0);
  Reconstruction model = ground_truth;
  model.Rig(rig_id).SensorFromRig(sensor_id).translation() +=
      Eigen::Vector3d(0.2 * baseline, 0, 0);
  model.UpdatePoint3DErrors();
  const Rigid3d perturbed = model.Rig(rig_id).SensorFromRig(sensor_id);
  const BundleAdjustmentOptions ba_options = AdjustmentOptions();
  ASSERT_TRUE(ba_options.refine_sensor_from_rig);

  Reconstruction held = model;
  ASSERT_TRUE(AdjustAllObservations(ba_options,
                                    ba_options.ceres->solver_options,
                                    &held,
                                    /*constant_cameras=*/{},
                                    /*constant_rigs=*/{rig_id})
                  .IsSolutionUsable());
  EXPECT_EQ(held.Rig(rig_id).SensorFromRig(sensor_id).translation(),
            perturbed.translation());
  Reconstruction held_on_tracks = model;
  ASSERT_TRUE(AdjustCamerasOnTracks(ba_options,
                                    ba_options.ceres->solver_options,
                                    SelectBundleTracks({}, model),
                                    &held_on_tracks,
                                    /*constant_cameras=*/{},
                                    /*constant_rigs=*/{rig_id}));
  EXPECT_EQ(held_on_tracks.Rig(rig_id).SensorFromRig(sensor_id).translation(),
            perturbed.translation());

  // Not held, the adjustment moves the camera back most of the way.
  ASSERT_TRUE(AdjustAllObservations(
                  ba_options, ba_options.ceres->solver_options, &model)
                  .IsSolutionUsable());
  EXPECT_LT((model.Rig(rig_id).SensorFromRig(sensor_id).translation() -
             true_sensor_from_rig.translation())
                .norm(),
            0.05 * baseline);
}

TEST(RefinePointsWithFixedCameras, LeavesCamerasAndExcludedPointsAlone) {
  const Reconstruction ground_truth = WellConditionedGroundTruth();
  Reconstruction model = Perturbed(ground_truth);
  const Reconstruction before = model;
  const point3D_t excluded = *model.Point3DIds().begin();
  RefinePointsWithFixedCameras(AdjustmentOptions(),
                               {excluded},
                               /*max_points_per_problem=*/1000,
                               &model);
  for (const image_t image_id : model.RegImageIds()) {
    EXPECT_EQ(model.Image(image_id).CamFromWorld().params,
              before.Image(image_id).CamFromWorld().params);
  }
  for (const auto& camera : model.Cameras()) {
    EXPECT_EQ(camera.second.params, before.Camera(camera.first).params);
  }
  EXPECT_EQ(model.Point3D(excluded).xyz, before.Point3D(excluded).xyz);
  model.UpdatePoint3DErrors();
  // Points moved back towards where the perturbed cameras see them.
  const Reconstruction& perturbed = before;
  EXPECT_LT(model.ComputeMeanReprojectionError(),
            0.8 * perturbed.ComputeMeanReprojectionError());
}

TEST(SolverSummaryToString, SaysHowTheSolveStopped) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_SCHUR;
  ceres::Solver::Summary summary;
  summary.iterations.resize(51);
  summary.initial_cost = 2.5e5;
  summary.final_cost = 2.4e5;
  summary.termination_type = ceres::NO_CONVERGENCE;
  EXPECT_EQ(SolverSummaryToString(options, summary, 13.75),
            "51 iterations, cost 2.5e+05 -> 2.4e+05, 13.8s (SPARSE_SCHUR, "
            "iteration limit)");
  summary.iterations.resize(4);
  summary.termination_type = ceres::CONVERGENCE;
  EXPECT_EQ(SolverSummaryToString(options, summary, 1.0),
            "4 iterations, cost 2.5e+05 -> 2.4e+05, 1.0s (SPARSE_SCHUR, "
            "converged)");
  summary.termination_type = ceres::FAILURE;
  summary.message = "Linear solver failed";
  EXPECT_NE(
      SolverSummaryToString(options, summary, 1.0).find("Linear solver failed"),
      std::string::npos);
}

}  // namespace
}  // namespace colmap
