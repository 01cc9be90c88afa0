#include "colmap_ext/sfm/community_merger.h"

#include "colmap_ext/scene/model_evaluation.h"
#include "colmap_ext/scene/synthetic_scene.h"
#include "colmap_ext/util/testing.h"

#include "colmap/geometry/pose.h"
#include "colmap/scene/database_cache.h"
#include "colmap/util/misc.h"

#include <set>

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

  SyntheticScene scene_;
  std::unordered_set<image_t> owned1_;
  std::unordered_set<image_t> owned2_;
  std::set<image_t> images1_;
  std::set<image_t> images2_;
  std::vector<Sim3d> community_from_world_;
};

TEST_F(JoinReconstructionsTest, RecoversTheScene) {
  Reconstruction model1 =
      CommunityModel(scene_.ground_truth, images1_, community_from_world_[0]);
  Reconstruction model2 =
      CommunityModel(scene_.ground_truth, images2_, community_from_world_[1]);
  // Community 2 refined the shared camera differently.
  const camera_t camera_id = model2.Cameras().begin()->first;
  model2.Camera(camera_id).params[0] *= 1.01;

  Reconstruction merged;
  std::vector<std::unordered_map<point3D_t, point3D_t>> point3D_ids;
  JoinReconstructions(
      {&model1, &model2},
      {Inverse(community_from_world_[0]), Inverse(community_from_world_[1])},
      {owned1_, owned2_},
      &merged,
      &point3D_ids);

  EXPECT_EQ(merged.NumRegImages(), scene_.ground_truth.NumRegImages());
  // Every image's pose is the truth's.
  for (const image_t image_id : scene_.ground_truth.RegImageIds()) {
    ASSERT_TRUE(merged.IsImageRegistered(image_id));
    const Image& truth = scene_.ground_truth.Image(image_id);
    const Image& image = merged.Image(image_id);
    EXPECT_LT((image.ProjectionCenter() - truth.ProjectionCenter()).norm(),
              1e-9);
    EXPECT_LT(image.CamFromWorld().rotation.angularDistance(
                  truth.CamFromWorld().rotation),
              1e-9);
    EXPECT_EQ(image.NumPoints2D(), truth.NumPoints2D());
  }
  // Points are in the world frame and observed only in owned images.
  for (size_t r = 0; r < 2; ++r) {
    const Reconstruction& model = r == 0 ? model1 : model2;
    const auto& owned = r == 0 ? owned1_ : owned2_;
    for (const auto& old_and_new : point3D_ids[r]) {
      const Point3D& point3D = merged.Point3D(old_and_new.second);
      const Eigen::Vector3d& truth_xyz =
          scene_.ground_truth.Point3D(old_and_new.first).xyz;
      EXPECT_LT((point3D.xyz - truth_xyz).norm(), 1e-6);
      for (const auto& track_el : point3D.track.Elements()) {
        EXPECT_EQ(owned.count(track_el.image_id), 1);
      }
      EXPECT_LE(point3D.track.Length(),
                model.Point3D(old_and_new.first).track.Length());
    }
  }
  // The shared camera comes from the community owning more of its images.
  const size_t expected_source = owned1_.size() >= owned2_.size() ? 0 : 1;
  EXPECT_EQ(merged.Camera(camera_id).params,
            (expected_source == 0 ? model1 : model2).Camera(camera_id).params);
}

TEST_F(JoinReconstructionsTest, MergesCorrespondingPoints) {
  Reconstruction model1 =
      CommunityModel(scene_.ground_truth, images1_, community_from_world_[0]);
  Reconstruction model2 =
      CommunityModel(scene_.ground_truth, images2_, community_from_world_[1]);
  Reconstruction merged;
  std::vector<std::unordered_map<point3D_t, point3D_t>> point3D_ids;
  JoinReconstructions(
      {&model1, &model2},
      {Inverse(community_from_world_[0]), Inverse(community_from_world_[1])},
      {owned1_, owned2_},
      &merged,
      &point3D_ids);

  // The two communities' copies of the same ground-truth point correspond.
  std::vector<std::pair<point3D_t, point3D_t>> pairs;
  for (const auto& old_and_new : point3D_ids[0]) {
    const auto it = point3D_ids[1].find(old_and_new.first);
    if (it != point3D_ids[1].end()) {
      pairs.emplace_back(old_and_new.second, it->second);
    }
  }
  ASSERT_GT(pairs.size(), 20);
  const size_t num_points_before = merged.NumPoints3D();

  const size_t num_merged = MergeCorrespondingPoints(pairs, &merged);

  EXPECT_EQ(num_merged, pairs.size());
  EXPECT_LE(merged.NumPoints3D(), num_points_before - num_merged);
  for (const auto& point3D : merged.Points3D()) {
    EXPECT_GE(point3D.second.track.Length(), 2);
  }
  // Merged points keep the truth's position.
  merged.UpdatePoint3DErrors();
  EXPECT_LT(merged.ComputeMeanReprojectionError(), 1e-6);
}

TEST_F(JoinReconstructionsTest, RestrictToImagesDropsBorrowedImages) {
  // Community 1's model with the three images it borrowed from community 2.
  auto model1 = std::make_shared<Reconstruction>(
      CommunityModel(scene_.ground_truth, images1_, community_from_world_[0]));
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
  auto model2 = std::make_shared<Reconstruction>(
      CommunityModel(scene_.ground_truth, images2_, community_from_world_[1]));
  EXPECT_EQ(RestrictToImages(owned2_, model2), model2);
}

// A community's mapper can register an image by what that community sees,
// far from where the whole model puts it (on South Building, 6 units off by
// points no other community had). In the merged model it then holds few
// observations, and the refinement must register it again rather than keep
// it there or drop it.
TEST(MergedModelRefiner, RegistersAgainAnImageItHoldsByFewObservations) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions scene_options;
  scene_options.num_clusters = 2;
  scene_options.num_images_per_cluster = 15;
  scene_options.num_images_per_link = 10;
  scene_options.close_loop = false;
  scene_options.keypoint_noise = 0.5;
  scene_options.seed = 12;
  Database database(JoinPaths(test_dir, "database.db"));
  SyntheticScene scene;
  SynthesizeCommunityScene(scene_options, &scene, &database);
  const std::shared_ptr<const DatabaseCache> database_cache =
      DatabaseCache::Create(database,
                            /*min_num_matches=*/15,
                            /*ignore_watermarks=*/false,
                            /*image_names=*/{});

  auto model = std::make_shared<Reconstruction>(scene.ground_truth);
  std::unordered_map<image_t, int> community_of_image;
  for (const image_t image_id : model->RegImageIds()) {
    community_of_image[image_id] = scene.image_cluster.at(image_id) == 1;
  }
  const ModelEvaluation truth = EvaluateModel(*model, scene.ground_truth);
  // An image of the first cluster, turned by 30 degrees and moved by a
  // quarter of the extent.
  const image_t misplaced =
      *std::find_if(model->RegImageIds().begin(),
                    model->RegImageIds().end(),
                    [&](const image_t image_id) {
                      return scene.image_cluster.at(image_id) == 0 &&
                             image_id != model->RegImageIds()[0] &&
                             image_id != model->RegImageIds()[1];
                    });
  Rigid3d& cam_from_world = model->Image(misplaced).CamFromWorld();
  cam_from_world = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(
                               DegToRad(30.0), Eigen::Vector3d::UnitY())),
                           Eigen::Vector3d(0.25 * truth.extent, 0, 0)) *
                   cam_from_world;
  ASSERT_GT(EvaluateModel(*model, scene.ground_truth).max_position_error,
            0.1 * truth.extent);
  // Its observations there were of points no other community has: none is
  // left in the merged model.
  for (point2D_t point2D_idx = 0;
       point2D_idx < model->Image(misplaced).NumPoints2D();
       ++point2D_idx) {
    if (model->Image(misplaced).Point2D(point2D_idx).HasPoint3D()) {
      model->DeleteObservation(misplaced, point2D_idx);
    }
  }

  IncrementalMapperOptions mapper_options;
  mapper_options.num_threads = 1;
  const MergedModelRefinementSummary summary =
      MergedModelRefiner(MergedModelRefinementOptions(),
                         mapper_options,
                         [&]() { return database_cache; },
                         community_of_image,
                         /*offered_models=*/{},
                         model)
          .Run();
  EXPECT_EQ(summary.num_reregistered_images, 1);
  EXPECT_EQ(summary.num_newly_registered_images, 0);
  EXPECT_TRUE(model->IsImageRegistered(misplaced));
  EXPECT_EQ(model->NumRegImages(), scene.ground_truth.NumRegImages());
  const ModelEvaluation evaluation = EvaluateModel(*model, scene.ground_truth);
  EXPECT_LT(evaluation.max_position_error, 0.01 * truth.extent);
}

// The refinement leaves pairs out of the merged model's correspondence
// graph (patches/0002): exactly those, and the others keep all their
// matches.
TEST(DatabaseCache, ImagePairFilterLeavesOutExactlyThePairsRefused) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 10;
  options.num_images_per_link = 6;
  options.num_points_per_cluster = 600;
  options.num_points_per_link = 300;
  options.seed = 5;
  Database database(JoinPaths(test_dir, "database.db"));
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, &database);

  std::vector<image_pair_t> pair_ids;
  std::vector<TwoViewGeometry> two_view_geometries;
  database.ReadTwoViewGeometries(&pair_ids, &two_view_geometries);
  ASSERT_GE(pair_ids.size(), 10);
  // Refuse every third pair.
  std::set<image_pair_t> refused;
  for (size_t i = 0; i < pair_ids.size(); i += 3) {
    refused.insert(pair_ids[i]);
  }
  const auto cache = DatabaseCache::Create(
      database,
      /*min_num_matches=*/1,
      /*ignore_watermarks=*/false,
      /*image_names=*/{},
      [&refused](const image_t image_id1, const image_t image_id2) {
        return refused.count(
                   Database::ImagePairToPairId(image_id1, image_id2)) == 0;
      });
  const auto& graph = *cache->CorrespondenceGraph();
  for (size_t i = 0; i < pair_ids.size(); ++i) {
    image_t image_id1;
    image_t image_id2;
    std::tie(image_id1, image_id2) = Database::PairIdToImagePair(pair_ids[i]);
    const size_t expected = refused.count(pair_ids[i]) > 0
                                ? 0
                                : two_view_geometries[i].inlier_matches.size();
    EXPECT_EQ(graph.NumCorrespondencesBetweenImages(image_id1, image_id2),
              expected)
        << i;
  }
}

// A subset of the images reads only the pairs among them (patches/0002),
// and gets exactly the correspondences that the whole database's cache has
// between them, in the same order of the two images.
TEST(DatabaseCache, ImageSubsetHasTheWholeCachesCorrespondences) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 10;
  options.num_images_per_link = 6;
  options.num_points_per_cluster = 600;
  options.num_points_per_link = 300;
  options.seed = 6;
  Database database(JoinPaths(test_dir, "database.db"));
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, &database);

  const auto whole = DatabaseCache::Create(database, 15, false, {});
  std::unordered_set<std::string> subset_names;
  std::vector<image_t> subset_ids;
  for (const Image& image : database.ReadAllImages()) {
    if (image.ImageId() % 2 == 0) {
      subset_names.insert(image.Name());
      subset_ids.push_back(image.ImageId());
    }
  }
  const auto subset = DatabaseCache::Create(database, 15, false, subset_names);
  size_t num_compared = 0;
  for (const image_t image_id1 : subset_ids) {
    // An image is left out only where it has no pair inside the subset.
    if (!subset->ExistsImage(image_id1) && whole->ExistsImage(image_id1)) {
      for (const image_t image_id2 : subset_ids) {
        if (image_id2 != image_id1 && whole->ExistsImage(image_id2)) {
          EXPECT_EQ(whole->CorrespondenceGraph()
                        ->FindCorrespondencesBetweenImages(image_id1, image_id2)
                        .size(),
                    0);
        }
      }
    }
    for (const image_t image_id2 : subset_ids) {
      if (image_id1 == image_id2 || !subset->ExistsImage(image_id1) ||
          !subset->ExistsImage(image_id2)) {
        continue;
      }
      const FeatureMatches expected =
          whole->CorrespondenceGraph()->FindCorrespondencesBetweenImages(
              image_id1, image_id2);
      const FeatureMatches found =
          subset->CorrespondenceGraph()->FindCorrespondencesBetweenImages(
              image_id1, image_id2);
      ASSERT_EQ(found.size(), expected.size());
      for (size_t i = 0; i < found.size(); ++i) {
        EXPECT_EQ(found[i].point2D_idx1, expected[i].point2D_idx1);
        EXPECT_EQ(found[i].point2D_idx2, expected[i].point2D_idx2);
      }
      num_compared += found.size();
    }
  }
  EXPECT_GT(num_compared, 1000);
  // Nothing of the other images.
  EXPECT_LT(subset->NumImages(), whole->NumImages());
}

}  // namespace
}  // namespace colmap
