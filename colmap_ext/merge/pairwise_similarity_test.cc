#include "colmap_ext/merge/pairwise_similarity.h"

#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/math/math.h"

#include <map>
#include <random>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// For every pair of images of the two groups that observe common points, the
// keypoint matches a matcher would find.
std::vector<CrossPairMatches> TrueCrossMatches(
    const Reconstruction& ground_truth,
    const std::set<image_t>& images1,
    const std::set<image_t>& images2) {
  std::map<std::pair<image_t, image_t>, FeatureMatches> matches;
  for (const auto& point3D : ground_truth.Points3D()) {
    for (const auto& el1 : point3D.second.track.Elements()) {
      for (const auto& el2 : point3D.second.track.Elements()) {
        if (images1.count(el1.image_id) && images2.count(el2.image_id)) {
          matches[{el1.image_id, el2.image_id}].emplace_back(el1.point2D_idx,
                                                             el2.point2D_idx);
        }
      }
    }
  }
  std::vector<CrossPairMatches> cross_pairs;
  for (auto& pair_and_matches : matches) {
    CrossPairMatches cross_pair;
    cross_pair.image_id1 = pair_and_matches.first.first;
    cross_pair.image_id2 = pair_and_matches.first.second;
    cross_pair.matches = std::move(pair_and_matches.second);
    cross_pairs.push_back(std::move(cross_pair));
  }
  return cross_pairs;
}

class PairwiseSimilarityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SyntheticSceneOptions options;
    options.num_clusters = 2;
    options.num_images_per_cluster = 20;
    options.num_images_per_link = 16;
    options.close_loop = false;
    options.keypoint_noise = 0;
    options.seed = 5;
    SynthesizeCommunityScene(options, &scene_, /*database=*/nullptr);
    // Community 1: cluster 0 and the walkway; community 2: cluster 1.
    for (const auto& image_and_cluster : scene_.image_cluster) {
      (image_and_cluster.second == 1 ? images2_ : images1_)
          .insert(image_and_cluster.first);
    }
    community1_from_world_ = Sim3d(
        0.1,
        Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())),
        Eigen::Vector3d(1, 2, 3));
    community2_from_world_ = Sim3d(
        2.5,
        Eigen::Quaterniond(Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d(-40, 7, 0.5));
  }

  SyntheticScene scene_;
  std::set<image_t> images1_;
  std::set<image_t> images2_;
  Sim3d community1_from_world_;
  Sim3d community2_from_world_;
};

TEST_F(PairwiseSimilarityTest, MatchesGroundTruth) {
  Reconstruction model1 =
      CommunityModel(scene_.ground_truth, images1_, community1_from_world_);
  Reconstruction model2 =
      CommunityModel(scene_.ground_truth, images2_, community2_from_world_);

  // Noise on every point, and a quarter of model 2's points far off, as
  // wrongly triangulated points would be.
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.01);
  int k = 0;
  for (const point3D_t point3D_id : model2.Point3DIds()) {
    Eigen::Vector3d& xyz = model2.Point3D(point3D_id).xyz;
    xyz += 2.5 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    if (++k % 4 == 0) {
      xyz += Eigen::Vector3d(50, -30, 20);
    }
  }

  const PointCorrespondences correspondences = FindPointCorrespondences(
      model1,
      model2,
      TrueCrossMatches(scene_.ground_truth, images1_, images2_));
  ASSERT_GT(correspondences.Size(), 100);

  const PairwiseSimilarity similarity =
      EstimatePairwiseSimilarity(correspondences, PairwiseSimilarityOptions());
  ASSERT_TRUE(similarity.success);
  EXPECT_LT(similarity.num_inliers, 0.8 * correspondences.Size());
  EXPECT_GT(similarity.num_inliers, 0.6 * correspondences.Size());

  const Sim3d truth = community2_from_world_ * Inverse(community1_from_world_);
  EXPECT_NEAR(
      similarity.second_from_first.scale() / truth.scale(), 1.0, 0.005);
  EXPECT_LT(RadToDeg(similarity.second_from_first.rotation().angularDistance(
                truth.rotation())),
            0.2);
  // Translation error relative to the scene in community 2's frame (~150 m
  // times 2.5).
  EXPECT_LT(
      (similarity.second_from_first.translation() - truth.translation())
          .norm(),
      0.5);
}

TEST_F(PairwiseSimilarityTest, EachPointPairCountsOnce) {
  const Reconstruction model1 =
      CommunityModel(scene_.ground_truth, images1_, community1_from_world_);
  const Reconstruction model2 =
      CommunityModel(scene_.ground_truth, images2_, community2_from_world_);
  std::vector<CrossPairMatches> cross_pairs =
      TrueCrossMatches(scene_.ground_truth, images1_, images2_);
  const size_t num_unique =
      FindPointCorrespondences(model1, model2, cross_pairs).Size();
  // The same matches twice give the same correspondences.
  std::vector<CrossPairMatches> doubled = cross_pairs;
  doubled.insert(doubled.end(), cross_pairs.begin(), cross_pairs.end());
  EXPECT_EQ(FindPointCorrespondences(model1, model2, doubled).Size(),
            num_unique);
}

TEST_F(PairwiseSimilarityTest, SharedImagesConfirmOnlyTheRightTransform) {
  // Model 1 borrowed three images of community 2.
  std::set<image_t> borrowed(images2_.begin(), std::next(images2_.begin(), 3));
  std::set<image_t> extended1 = images1_;
  extended1.insert(borrowed.begin(), borrowed.end());
  Reconstruction model1 =
      CommunityModel(scene_.ground_truth, extended1, community1_from_world_);
  const Reconstruction model2 =
      CommunityModel(scene_.ground_truth, images2_, community2_from_world_);
  std::vector<Eigen::Vector3d> points2;
  for (const auto& point3D : model2.Points3D()) {
    points2.push_back(point3D.second.xyz);
  }
  const double spread = MedianDistanceToMedian(points2);
  const Sim3d truth = community2_from_world_ * Inverse(community1_from_world_);

  SharedImageAgreement agreement =
      CheckSharedImages(model1, model2, truth, spread);
  EXPECT_EQ(agreement.num_shared_images, 3);
  EXPECT_EQ(agreement.num_agreeing, 3);
  EXPECT_EQ(agreement.num_agreeing, agreement.num_shared_images);
  EXPECT_LT(agreement.max_rotation_deg, 1e-6);
  EXPECT_LT(agreement.max_relative_distance, 1e-6);

  // A transform 20 degrees off places none alike.
  const Sim3d wrong = Sim3d(1,
                            Eigen::Quaterniond(Eigen::AngleAxisd(
                                DegToRad(20.0), Eigen::Vector3d::UnitY())),
                            Eigen::Vector3d::Zero()) *
                      truth;
  agreement = CheckSharedImages(model1, model2, wrong, spread);
  EXPECT_EQ(agreement.num_agreeing, 0);
  EXPECT_NEAR(agreement.max_rotation_deg, 20.0, 1e-6);

  // Model 1 turned one borrowed image by 30 degrees about its centre: the
  // right transform places the other two alike.
  const Image& turned = model1.Image(*borrowed.begin());
  const Rigid3d cam_from_world = turned.CamFromWorld();
  const Eigen::Quaterniond turn(
      Eigen::AngleAxisd(DegToRad(30.0), Eigen::Vector3d::UnitZ()));
  model1.Frame(turned.FrameId())
      .SetCamFromWorld(turned.CameraId(),
                       Rigid3d(turn * cam_from_world.rotation(),
                               turn * cam_from_world.translation()));
  agreement = CheckSharedImages(model1, model2, truth, spread);
  EXPECT_EQ(agreement.num_shared_images, 3);
  EXPECT_EQ(agreement.num_agreeing, 2);
  EXPECT_LT(agreement.num_agreeing, agreement.num_shared_images);
  EXPECT_NEAR(agreement.max_rotation_deg, 30.0, 1e-6);
  EXPECT_LT(agreement.max_relative_distance, 1e-6);
}

TEST_F(PairwiseSimilarityTest, OnlyTheRightTransformExplainsTheCrossPairs) {
  const Reconstruction model1 =
      CommunityModel(scene_.ground_truth, images1_, community1_from_world_);
  const Reconstruction model2 =
      CommunityModel(scene_.ground_truth, images2_, community2_from_world_);
  const std::vector<CrossPairMatches> cross_pairs =
      TrueCrossMatches(scene_.ground_truth, images1_, images2_);
  ASSERT_GT(cross_pairs.size(), 5);
  const Sim3d truth = community2_from_world_ * Inverse(community1_from_world_);
  EXPECT_EQ(CountExplainedCrossPairs(model1, model2, truth, cross_pairs),
            cross_pairs.size());

  // Turned by 90 degrees about the centre of community 2's cameras, as a
  // community folded onto look-alike structure would place it: no pair's
  // matches fit the epipolar geometry.
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  for (const image_t image_id : model2.RegImageIds()) {
    center += model2.Image(image_id).ProjectionCenter();
  }
  center /= model2.NumRegImages();
  const Eigen::Quaterniond turn(
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));
  const Sim3d turned = Sim3d(1, turn, center - turn * center) * truth;
  EXPECT_EQ(CountExplainedCrossPairs(model1, model2, turned, cross_pairs), 0);

  // Pairs of images a model did not register are not counted.
  Reconstruction partial2 = model2;
  for (const CrossPairMatches& pair : cross_pairs) {
    if (partial2.Image(pair.image_id2).HasPose()) {
      partial2.DeRegisterFrame(partial2.Image(pair.image_id2).FrameId());
    }
  }
  EXPECT_EQ(CountExplainedCrossPairs(model1, partial2, truth, cross_pairs), 0);
}

TEST(EstimatePairwiseSimilarity, TooFewCorrespondences) {
  PointCorrespondences correspondences;
  for (int i = 0; i < 5; ++i) {
    correspondences.point3D_ids1.push_back(i + 1);
    correspondences.point3D_ids2.push_back(i + 1);
    correspondences.points1.push_back(Eigen::Vector3d::Random());
    correspondences.points2.push_back(correspondences.points1.back());
  }
  const PairwiseSimilarity similarity =
      EstimatePairwiseSimilarity(correspondences, PairwiseSimilarityOptions());
  EXPECT_FALSE(similarity.success);
  EXPECT_EQ(similarity.num_inliers, 0);
}

}  // namespace
}  // namespace colmap
