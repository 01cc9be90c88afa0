#include "colmap_ext/testing/model_evaluation.h"

#include "colmap_ext/testing/synthetic_scene.h"

#include "colmap/math/math.h"

#include <algorithm>

#include <gtest/gtest.h>

namespace colmap {
namespace {

SyntheticSceneOptions SceneOptions() {
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 15;
  options.num_images_per_link = 10;
  options.close_loop = false;
  options.num_points_per_cluster = 300;
  options.num_points_per_link = 100;
  options.seed = 2;
  return options;
}

Reconstruction GroundTruth(const SyntheticSceneOptions& options = SceneOptions()) {
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, /*database=*/nullptr);
  return scene.ground_truth;
}

// The scene above taken by a stereo rig, its second camera 0.3 m to the
// right of the first, turned right by 2 degrees.
Reconstruction StereoGroundTruth() {
  SyntheticSceneOptions options = SceneOptions();
  options.num_rig_cameras = 2;
  options.rig_baseline = 0.3;
  options.rig_yaw_deg = 2.0;
  return GroundTruth(options);
}

// The rig's only non-reference camera.
sensor_t SecondRigCamera(const Reconstruction& reconstruction, rig_t* rig_id) {
  for (const auto& [id, rig] : reconstruction.Rigs()) {
    if (rig.NumSensors() == 2) {
      *rig_id = id;
      return rig.NonRefSensors().begin()->first;
    }
  }
  return kInvalidSensorId;
}

// The same registered images, each in a frame of its own, as a mapper that
// knows nothing of the rig makes them (no points).
Reconstruction WithTrivialFrames(const Reconstruction& reconstruction) {
  Reconstruction trivial;
  for (const auto& [_, camera] : reconstruction.Cameras()) {
    trivial.AddCameraWithTrivialRig(camera);
  }
  for (const image_t image_id : reconstruction.RegImageIds()) {
    const Image& image = reconstruction.Image(image_id);
    Image copy;
    copy.SetImageId(image_id);
    copy.SetName(image.Name());
    copy.SetCameraId(image.CameraId());
    trivial.AddImageWithTrivialFrame(copy, image.CamFromWorld());
  }
  return trivial;
}

// Moves the image's camera centre to `center`, its rotation kept.
void MoveCenter(const Eigen::Vector3d& center,
                const Image& image,
                Reconstruction* model) {
  Rigid3d cam_from_world = image.CamFromWorld();
  cam_from_world.translation() = -(cam_from_world.rotation() * center);
  model->Frame(image.FrameId())
      .SetCamFromWorld(image.CameraId(), cam_from_world);
}

TEST(EvaluateModel, SimilarModelHasNoError) {
  const Reconstruction ground_truth = GroundTruth();
  Reconstruction model = ground_truth;
  model.Transform(Sim3d(0.01,
                        Eigen::Quaterniond(Eigen::AngleAxisd(
                            2.0, Eigen::Vector3d(1, 2, 3).normalized())),
                        Eigen::Vector3d(5, -2, 1)));

  const ModelEvaluation evaluation = EvaluateModel(model, ground_truth);
  EXPECT_EQ(evaluation.num_ground_truth_images, 40);
  EXPECT_EQ(evaluation.num_registered_images, 40);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_LT(evaluation.max_position_error, 1e-6);
  EXPECT_LT(evaluation.median_rotation_error_deg, 1e-6);
  EXPECT_NEAR(evaluation.ground_truth_from_model.scale(), 100.0, 1e-6);
  // Without a multi-camera rig, no rig figures.
  EXPECT_TRUE(evaluation.rig_camera_ids.empty());
  EXPECT_EQ(ModelEvaluationToString(evaluation).find("rig_"),
            std::string::npos);
}

TEST(EvaluateModel, RigOfTheGroundTruthHasNoError) {
  const Reconstruction ground_truth = StereoGroundTruth();
  Reconstruction model = ground_truth;
  model.Transform(Sim3d(0.01,
                        Eigen::Quaterniond(Eigen::AngleAxisd(
                            2.0, Eigen::Vector3d(1, 2, 3).normalized())),
                        Eigen::Vector3d(5, -2, 1)));

  for (const Reconstruction& candidate : {model, WithTrivialFrames(model)}) {
    const ModelEvaluation evaluation = EvaluateModel(candidate, ground_truth);
    EXPECT_EQ(evaluation.num_registered_images, 80);
    ASSERT_TRUE(evaluation.aligned);
    ASSERT_EQ(evaluation.rig_camera_ids.size(), 1);
    EXPECT_LT(evaluation.rig_rotation_error_deg, 1e-6);
    EXPECT_LT(evaluation.rig_baseline_error_fraction, 1e-6);
    const std::string text = ModelEvaluationToString(evaluation);
    EXPECT_NE(text.find("rig_rotation_error_deg "), std::string::npos);
    EXPECT_NE(text.find("rig_baseline_error_fraction "), std::string::npos);
  }
}

// A model whose rig baseline is 10% too long, as its rig or from the poses
// of its images in frames of their own.
TEST(EvaluateModel, MeasuresRigBaselineError) {
  const Reconstruction ground_truth = StereoGroundTruth();
  Reconstruction model = ground_truth;
  rig_t rig_id = kInvalidRigId;
  const sensor_t sensor_id = SecondRigCamera(model, &rig_id);
  ASSERT_NE(rig_id, kInvalidRigId);
  model.Rig(rig_id).SensorFromRig(sensor_id).translation() *= 1.1;

  for (const Reconstruction& candidate : {model, WithTrivialFrames(model)}) {
    const ModelEvaluation evaluation = EvaluateModel(candidate, ground_truth);
    ASSERT_TRUE(evaluation.aligned);
    ASSERT_EQ(evaluation.rig_camera_ids.size(), 1);
    EXPECT_EQ(evaluation.rig_camera_ids[0], sensor_id.id);
    EXPECT_LT(evaluation.rig_rotation_error_deg, 1e-6);
    EXPECT_NEAR(evaluation.rig_baseline_error_fraction, 0.1, 0.005);
  }
}

TEST(EvaluateModel, MeasuresPositionErrorsAfterAlignment) {
  const Reconstruction ground_truth = GroundTruth();
  Reconstruction model = ground_truth;
  // Every camera moved by 0.1 m along x, one by 20 m (an outlier of the
  // alignment), one not registered.
  std::vector<image_t> image_ids = model.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  for (size_t i = 0; i < image_ids.size(); ++i) {
    const Image& image = model.Image(image_ids[i]);
    const Eigen::Vector3d offset(
        i == 0 ? 20.0 : (i % 2 == 0 ? 0.1 : -0.1), 0, 0);
    MoveCenter(image.ProjectionCenter() + offset, image, &model);
  }
  model.DeRegisterFrame(model.Image(image_ids[1]).FrameId());

  const ModelEvaluation evaluation = EvaluateModel(model, ground_truth);
  EXPECT_EQ(evaluation.num_registered_images, 39);
  ASSERT_TRUE(evaluation.aligned);
  EXPECT_NEAR(evaluation.median_position_error, 0.1, 0.01);
  EXPECT_NEAR(evaluation.max_position_error, 20.0, 0.5);
  EXPECT_LT(evaluation.median_rotation_error_deg, 0.01);
  // The extent is the diagonal of the cameras' bounding box.
  Eigen::AlignedBox3d box;
  for (const image_t image_id : ground_truth.RegImageIds()) {
    box.extend(ground_truth.Image(image_id).ProjectionCenter());
  }
  EXPECT_NEAR(evaluation.extent, box.diagonal().norm(), 1e-9);
  EXPECT_EQ(evaluation.image_names.size(), 39);
  EXPECT_EQ(evaluation.aligned_centers.size(), 39);
}

// A model whose two halves are each right but placed 1 m apart: together
// they are in error, each alone is not (a merged model judged against the
// communities it was made of).
TEST(EvaluateModel, SelectedImagesAreAlignedAlone) {
  const Reconstruction ground_truth = GroundTruth();
  Reconstruction model = ground_truth;
  std::vector<image_t> image_ids = model.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  ModelEvaluationOptions first_half;
  ModelEvaluationOptions second_half;
  for (size_t i = 0; i < image_ids.size(); ++i) {
    const Image& image = model.Image(image_ids[i]);
    if (i < image_ids.size() / 2) {
      first_half.image_names.push_back(image.Name());
      continue;
    }
    second_half.image_names.push_back(image.Name());
    MoveCenter(
        image.ProjectionCenter() + Eigen::Vector3d(0, 0, 1), image, &model);
  }

  const ModelEvaluation whole = EvaluateModel(model, ground_truth);
  ASSERT_TRUE(whole.aligned);
  EXPECT_GT(whole.median_position_error, 0.3);
  for (const ModelEvaluationOptions& options : {first_half, second_half}) {
    const ModelEvaluation half = EvaluateModel(model, ground_truth, options);
    EXPECT_EQ(half.num_registered_images, 20);
    std::vector<std::string> names = options.image_names;
    std::sort(names.begin(), names.end());
    EXPECT_EQ(half.image_names, names);
    ASSERT_TRUE(half.aligned);
    EXPECT_LT(half.max_position_error, 1e-6);
    EXPECT_NEAR(half.extent, whole.extent, 1e-9);
  }
}

TEST(EvaluateModel, TooFewImagesAreNotAligned) {
  const Reconstruction ground_truth = GroundTruth();
  const ModelEvaluation evaluation =
      EvaluateModel(Reconstruction(), ground_truth);
  EXPECT_EQ(evaluation.num_registered_images, 0);
  EXPECT_FALSE(evaluation.aligned);
  EXPECT_TRUE(std::isnan(evaluation.median_position_error));
  EXPECT_NE(ModelEvaluationToString(evaluation).find("aligned 0\n"),
            std::string::npos);
}

}  // namespace
}  // namespace colmap
