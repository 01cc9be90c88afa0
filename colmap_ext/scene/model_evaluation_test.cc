#include "colmap_ext/scene/model_evaluation.h"

#include "colmap_ext/scene/synthetic_scene.h"

#include "colmap/math/math.h"

#include <algorithm>

#include <gtest/gtest.h>

namespace colmap {
namespace {

Reconstruction GroundTruth() {
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 15;
  options.num_images_per_link = 10;
  options.close_loop = false;
  options.num_points_per_cluster = 300;
  options.num_points_per_link = 100;
  options.seed = 2;
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, /*database=*/nullptr);
  return scene.ground_truth;
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
  EXPECT_NEAR(evaluation.ground_truth_from_model.scale, 100.0, 1e-6);
}

TEST(EvaluateModel, MeasuresPositionErrorsAfterAlignment) {
  const Reconstruction ground_truth = GroundTruth();
  Reconstruction model = ground_truth;
  // Every camera moved by 0.1 m along x, one by 20 m (an outlier of the
  // alignment), one not registered.
  std::vector<image_t> image_ids = model.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  for (size_t i = 0; i < image_ids.size(); ++i) {
    Image& image = model.Image(image_ids[i]);
    const Eigen::Vector3d offset(
        i == 0 ? 20.0 : (i % 2 == 0 ? 0.1 : -0.1), 0, 0);
    const Eigen::Vector3d center = image.ProjectionCenter() + offset;
    image.CamFromWorld().translation =
        -(image.CamFromWorld().rotation * center);
  }
  model.DeRegisterImage(image_ids[1]);

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
    Image& image = model.Image(image_ids[i]);
    if (i < image_ids.size() / 2) {
      first_half.image_names.push_back(image.Name());
      continue;
    }
    second_half.image_names.push_back(image.Name());
    const Eigen::Vector3d center =
        image.ProjectionCenter() + Eigen::Vector3d(0, 0, 1);
    image.CamFromWorld().translation =
        -(image.CamFromWorld().rotation * center);
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
