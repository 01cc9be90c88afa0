#include "colmap_ext/merge/model_join.h"

#include "colmap_ext/testing/model_evaluation.h"
#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/geometry/pose.h"
#include "colmap/math/math.h"
#include "colmap/math/random.h"
#include "colmap/scene/database_cache.h"
#include "colmap/scene/synthetic.h"

#include <algorithm>
#include <filesystem>
#include <set>
#include <vector>

#include <gtest/gtest.h>

namespace colmap {
namespace {

class JoinReconstructionsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SyntheticSceneOptions options;
    options.num_clusters = 2;
    options.num_images_per_cluster = 15;
    options.num_images_per_link = 12;
    options.close_loop = false;
    options.keypoint_noise = 0;
    options.seed = 9;
    SynthesizeCommunityScene(options, &scene_, /*database=*/nullptr);
    for (const auto& image_and_cluster : scene_.image_cluster) {
      (image_and_cluster.second == 1 ? owned2_ : owned1_)
          .insert(image_and_cluster.first);
    }
    // Community 1 also registers three images of community 2.
    images1_ = std::set<image_t>(owned1_.begin(), owned1_.end());
    images2_ = std::set<image_t>(owned2_.begin(), owned2_.end());
    auto it = owned2_.begin();
    for (int i = 0; i < 3; ++i, ++it) {
      images1_.insert(*it);
    }
    community_from_world_ = {Sim3d(0.5,
                                   Eigen::Quaterniond(Eigen::AngleAxisd(
                                       0.4, Eigen::Vector3d::UnitY())),
                                   Eigen::Vector3d(3, 0, -1)),
                             Sim3d(3.0,
                                   Eigen::Quaterniond(Eigen::AngleAxisd(
                                       2.0, Eigen::Vector3d::UnitZ())),
                                   Eigen::Vector3d(0, 10, 0))};
  }

  // Community c's model (c = 0, 1) in its own frame, with the images it
  // registered.
  Reconstruction Community(const size_t c) const {
    return CommunityModel(scene_.ground_truth,
                          c == 0 ? images1_ : images2_,
                          community_from_world_[c]);
  }

  // The two communities' models joined in the world frame.
  void Join(Reconstruction* model1,
            Reconstruction* model2,
            Reconstruction* merged) const {
    JoinReconstructions(
        {model1, model2},
        {Inverse(community_from_world_[0]), Inverse(community_from_world_[1])},
        {owned1_, owned2_},
        merged);
  }

  SyntheticScene scene_;
  std::unordered_set<image_t> owned1_;
  std::unordered_set<image_t> owned2_;
  std::set<image_t> images1_;
  std::set<image_t> images2_;
  std::vector<Sim3d> community_from_world_;
};

TEST_F(JoinReconstructionsTest, RecoversTheScene) {
  Reconstruction model1 = Community(0);
  Reconstruction model2 = Community(1);
  // Community 2 refined the shared camera differently.
  const camera_t camera_id = model2.Cameras().begin()->first;
  model2.Camera(camera_id).params[0] *= 1.01;

  Reconstruction merged;
  Join(&model1, &model2, &merged);

  EXPECT_EQ(merged.NumRegImages(), scene_.ground_truth.NumRegImages());
  // Every image's pose is the truth's.
  for (const image_t image_id : scene_.ground_truth.RegImageIds()) {
    ASSERT_TRUE(merged.ExistsImage(image_id));
    const Image& truth = scene_.ground_truth.Image(image_id);
    const Image& image = merged.Image(image_id);
    ASSERT_TRUE(image.HasPose());
    EXPECT_EQ(image.FrameId(), truth.FrameId());
    EXPECT_LT((image.ProjectionCenter() - truth.ProjectionCenter()).norm(),
              1e-9);
    EXPECT_LT(image.CamFromWorld().rotation().angularDistance(
                  truth.CamFromWorld().rotation()),
              1e-9);
    EXPECT_EQ(image.NumPoints2D(), truth.NumPoints2D());
  }
  // Points are in the world frame, each observed in the images one
  // community owns.
  EXPECT_GT(merged.NumPoints3D(), 0);
  for (const auto& [point3D_id, point3D] : merged.Points3D()) {
    const TrackElement& first = point3D.track.Element(0);
    const Eigen::Vector3d& truth_xyz =
        scene_.ground_truth
            .Point3D(scene_.ground_truth.Image(first.image_id)
                         .Point2D(first.point2D_idx)
                         .point3D_id)
            .xyz;
    EXPECT_LT((point3D.xyz - truth_xyz).norm(), 1e-6);
    const auto& owned = owned1_.count(first.image_id) ? owned1_ : owned2_;
    for (const auto& track_el : point3D.track.Elements()) {
      EXPECT_EQ(owned.count(track_el.image_id), 1);
    }
  }
  // The shared camera comes from the community owning more of its images.
  const size_t expected_source = owned1_.size() >= owned2_.size() ? 0 : 1;
  EXPECT_EQ(merged.Camera(camera_id).params,
            (expected_source == 0 ? model1 : model2).Camera(camera_id).params);
}

TEST_F(JoinReconstructionsTest, RestrictToImagesDropsBorrowedImages) {
  // Community 1's model with the three images it borrowed from community 2.
  auto model1 = std::make_shared<Reconstruction>(Community(0));
  const std::shared_ptr<Reconstruction> own = RestrictToImages(owned1_, model1);

  ASSERT_NE(own, model1);
  EXPECT_EQ(own->NumRegImages(), owned1_.size());
  for (const image_t image_id : own->RegImageIds()) {
    EXPECT_EQ(owned1_.count(image_id), 1);
    // Poses stay in the community's frame.
    EXPECT_LT((own->Image(image_id).ProjectionCenter() -
               model1->Image(image_id).ProjectionCenter())
                  .norm(),
              1e-9);
  }
  for (const auto& point3D : own->Points3D()) {
    EXPECT_GE(point3D.second.track.Length(), 2);
    for (const auto& track_el : point3D.second.track.Elements()) {
      EXPECT_EQ(owned1_.count(track_el.image_id), 1);
    }
  }
  EXPECT_GT(own->NumPoints3D(), 0);
  EXPECT_LE(own->NumPoints3D(), model1->NumPoints3D());

  // A model of its own images only is returned as it is.
  auto model2 = std::make_shared<Reconstruction>(Community(1));
  EXPECT_EQ(RestrictToImages(owned2_, model2), model2);
}

// A rig's snapshot (a frame) whose images two reconstructions own comes
// whole from the first of them, with the rig's calibration.
TEST(JoinReconstructions, KeepsAFramesImagesTogether) {
  SetPRNGSeed(1);
  SyntheticDatasetOptions options;
  options.num_rigs = 1;
  options.num_cameras_per_rig = 2;
  options.num_frames_per_rig = 4;
  options.num_points3D = 50;
  Reconstruction truth;
  SynthesizeDataset(options, &truth);
  Reconstruction model1 = truth;
  Reconstruction model2 = truth;
  const frame_t split_frame_id = truth.RegFrameIds()[0];
  std::vector<image_t> split_image_ids;
  for (const data_t& data_id : truth.Frame(split_frame_id).ImageIds()) {
    split_image_ids.push_back(data_id.id);
  }
  ASSERT_EQ(split_image_ids.size(), 2);
  // Model 1 owns one image of the frame, model 2 every other image.
  const std::unordered_set<image_t> owned1 = {split_image_ids[0]};
  std::unordered_set<image_t> owned2;
  for (const image_t image_id : truth.RegImageIds()) {
    if (image_id != split_image_ids[0]) {
      owned2.insert(image_id);
    }
  }

  Reconstruction merged;
  JoinReconstructions(
      {&model1, &model2}, {Sim3d(), Sim3d()}, {owned1, owned2}, &merged);

  EXPECT_TRUE(merged.IsValid());
  EXPECT_EQ(merged.NumRegFrames(), truth.NumRegFrames());
  EXPECT_EQ(merged.NumRegImages(), truth.NumRegImages());
  for (const image_t image_id : split_image_ids) {
    ASSERT_TRUE(merged.Image(image_id).HasPose());
    EXPECT_EQ(merged.Image(image_id).FrameId(), split_frame_id);
    EXPECT_LT((merged.Image(image_id).ProjectionCenter() -
               truth.Image(image_id).ProjectionCenter())
                  .norm(),
              1e-9);
  }
  const rig_t rig_id = truth.Frame(split_frame_id).RigId();
  EXPECT_EQ(merged.Rig(rig_id), truth.Rig(rig_id));
  // The frame's observations are model 1's, the others model 2's: no
  // point is observed both in the frame and outside it.
  std::set<bool> in_frame_of_points;
  for (const auto& [point3D_id, point3D] : merged.Points3D()) {
    std::set<bool> in_frame;
    for (const TrackElement& track_el : point3D.track.Elements()) {
      in_frame.insert(merged.Image(track_el.image_id).FrameId() ==
                      split_frame_id);
    }
    EXPECT_EQ(in_frame.size(), 1);
    in_frame_of_points.insert(in_frame.begin(), in_frame.end());
  }
  EXPECT_EQ(in_frame_of_points.size(), 2);
}

}  // namespace
}  // namespace colmap
