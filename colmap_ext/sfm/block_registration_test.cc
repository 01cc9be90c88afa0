#include "colmap_ext/sfm/block_registration.h"

#include "colmap_ext/scene/synthetic_scene.h"
#include "colmap_ext/util/testing.h"

#include "colmap/geometry/pose.h"
#include "colmap/math/math.h"

#include <set>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// Two landmarks joined by a walkway: the merged model holds landmark 0 and
// the walkway in the world frame and `num_shared` images of landmark 1
// (registered one by one, say); the community model holds landmark 1 in a
// frame of its own.
class BlockRegistrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SynthesizeTwoLandmarks(
        /*single_camera=*/false, &scene_, &merged_images_, &community_images_);
    model_from_world_ = Sim3d(
        0.2,
        Eigen::Quaterniond(Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitY())),
        Eigen::Vector3d(5, -3, 8));
    model_ = CommunityModel(
        scene_.ground_truth, community_images_, model_from_world_);
  }

  // The merged model with the first `num_shared` images of landmark 1.
  Reconstruction Merged(const int num_shared) const {
    std::set<image_t> image_ids = merged_images_;
    auto it = community_images_.begin();
    for (int i = 0; i < num_shared; ++i, ++it) {
      image_ids.insert(*it);
    }
    return CommunityModel(scene_.ground_truth, image_ids, Sim3d());
  }

  SyntheticScene scene_;
  std::set<image_t> merged_images_;
  std::set<image_t> community_images_;
  Sim3d model_from_world_;
  Reconstruction model_;
};

TEST_F(BlockRegistrationTest, PlacesTheModelsOtherImagesAsTheGroundTruth) {
  Reconstruction merged = Merged(3);
  // The merged model knows only the database's prior of the community's
  // cameras; the model refined them.
  for (const image_t image_id : community_images_) {
    if (!merged.Image(image_id).HasPose()) {
      merged.Camera(merged.Image(image_id).CameraId()).params[0] *= 1.3;
    }
  }
  const BlockRegistration block =
      EstimateBlockRegistration(model_, merged, BlockRegistrationOptions());
  ASSERT_TRUE(block.success);
  EXPECT_EQ(block.num_shared_images, 3);
  EXPECT_EQ(block.image_ids.size(), community_images_.size() - 3);
  EXPECT_GT(block.num_inliers, 100);
  EXPECT_NEAR(
      block.merged_from_model.scale() * model_from_world_.scale(), 1.0, 1e-6);

  const size_t num_registered = merged.NumRegImages();
  ApplyBlockRegistration(model_, block, &merged);
  EXPECT_EQ(merged.NumRegImages(), num_registered + block.image_ids.size());
  for (const image_t image_id : community_images_) {
    const Image& image = merged.Image(image_id);
    const Image& truth = scene_.ground_truth.Image(image_id);
    ASSERT_TRUE(image.HasPose());
    EXPECT_LT((image.ProjectionCenter() - truth.ProjectionCenter()).norm(),
              1e-6);
    EXPECT_LT(RadToDeg(image.CamFromWorld().rotation().angularDistance(
                  truth.CamFromWorld().rotation())),
              1e-6);
    EXPECT_EQ(merged.Camera(image.CameraId()).params,
              scene_.ground_truth.Camera(image.CameraId()).params)
        << "image " << image_id;
  }
}

// One camera for all images: the merged model's other images use it, so
// it keeps the merged model's intrinsics; where only the model's images use
// it, it takes the model's.
TEST(BlockRegistration, ASharedCameraKeepsTheIntrinsicsOfTheMergedModel) {
  SyntheticScene scene;
  std::set<image_t> landmark0;
  std::set<image_t> landmark1;
  SynthesizeTwoLandmarks(
      /*single_camera=*/true, &scene, &landmark0, &landmark1);
  const Reconstruction model =
      CommunityModel(scene.ground_truth, landmark1, Sim3d());
  std::set<image_t> shared(landmark1.begin(), std::next(landmark1.begin(), 3));
  const camera_t camera_id =
      scene.ground_truth.Image(*landmark1.begin()).CameraId();
  const std::vector<double> truth = model.Camera(camera_id).params;

  for (const bool with_landmark0 : {true, false}) {
    std::set<image_t> image_ids = shared;
    if (with_landmark0) {
      image_ids.insert(landmark0.begin(), landmark0.end());
    }
    Reconstruction merged =
        CommunityModel(scene.ground_truth, image_ids, Sim3d());
    merged.Camera(camera_id).params[0] *= 1.3;
    const std::vector<double> prior = merged.Camera(camera_id).params;
    const BlockRegistration block =
        EstimateBlockRegistration(model, merged, BlockRegistrationOptions());
    ASSERT_TRUE(block.success);
    ApplyBlockRegistration(model, block, &merged);
    EXPECT_EQ(merged.Camera(camera_id).params, with_landmark0 ? prior : truth)
        << "with landmark 0: " << with_landmark0;
  }
}

TEST_F(BlockRegistrationTest, TooFewSharedImagesRegisterNothing) {
  const BlockRegistration block =
      EstimateBlockRegistration(model_, Merged(2), BlockRegistrationOptions());
  EXPECT_FALSE(block.success);
  EXPECT_EQ(block.num_shared_images, 2);

  BlockRegistrationOptions options;
  options.min_num_shared_images = 2;
  EXPECT_TRUE(EstimateBlockRegistration(model_, Merged(2), options).success);
}

// A shared image that the merged model placed wrongly (turned by 30 degrees
// about its centre, as a wrong registration leaves it) contradicts every
// transform its neighbours support: no block is registered through it.
TEST_F(BlockRegistrationTest, AContradictingSharedImageRegistersNothing) {
  Reconstruction merged = Merged(4);
  const image_t wrong_image_id = *community_images_.begin();
  const Image& wrong = merged.Image(wrong_image_id);
  const Eigen::Vector3d center = wrong.ProjectionCenter();
  const Eigen::Quaterniond turned =
      wrong.CamFromWorld().rotation() *
      Eigen::Quaterniond(
          Eigen::AngleAxisd(DegToRad(30.0), Eigen::Vector3d::UnitY()));
  merged.Frame(wrong.FrameId())
      .SetCamFromWorld(wrong.CameraId(), Rigid3d(turned, -(turned * center)));
  ASSERT_LT((wrong.ProjectionCenter() - center).norm(), 1e-9);

  const BlockRegistration block =
      EstimateBlockRegistration(model_, merged, BlockRegistrationOptions());
  EXPECT_EQ(block.num_shared_images, 4);
  EXPECT_FALSE(block.success);
}

// A model bent inside itself (here: the points of half its images moved
// away, as a community that drifted) agrees with the merged model on few
// of the shared images' points: no block, though a transform fits some.
TEST_F(BlockRegistrationTest,
       AModelThatExplainsFewOfThePointsRegistersNothing) {
  const Reconstruction merged = Merged(4);
  std::set<point3D_t> moved;
  int i = 0;
  for (const image_t image_id : community_images_) {
    if (i++ % 2 == 1) {
      for (const Point2D& point2D : model_.Image(image_id).Points2D()) {
        if (point2D.HasPoint3D()) {
          moved.insert(point2D.point3D_id);
        }
      }
    }
  }
  for (const point3D_t point3D_id : moved) {
    model_.Point3D(point3D_id).xyz += Eigen::Vector3d(3, -2, 4);
  }
  BlockRegistrationOptions options;
  options.min_inlier_fraction = 0;
  const BlockRegistration lenient =
      EstimateBlockRegistration(model_, merged, options);
  EXPECT_TRUE(lenient.success);
  EXPECT_LT(lenient.num_inliers, 0.5 * lenient.num_correspondences);

  const BlockRegistration block =
      EstimateBlockRegistration(model_, merged, BlockRegistrationOptions());
  EXPECT_FALSE(block.success);
}

// Nothing left to register (the merged model holds all the model's images
// already): no block, whatever the transform.
TEST_F(BlockRegistrationTest, NothingLeftToRegister) {
  const BlockRegistration block = EstimateBlockRegistration(
      model_,
      Merged(static_cast<int>(community_images_.size())),
      BlockRegistrationOptions());
  EXPECT_FALSE(block.success);
  EXPECT_TRUE(block.image_ids.empty());
}

}  // namespace
}  // namespace colmap
