#include "colmap_ext/scene/synthetic_scene.h"

#include "colmap_ext/util/testing.h"

#include "colmap/util/misc.h"

#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

namespace colmap {
namespace {

std::string ReadBytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file),
                     std::istreambuf_iterator<char>());
}

SyntheticSceneOptions SmallScene() {
  SyntheticSceneOptions options;
  options.num_clusters = 3;
  options.num_images_per_cluster = 12;
  options.num_images_per_link = 10;
  options.num_points_per_cluster = 800;
  options.num_points_per_link = 400;
  options.keypoint_noise = 0.5;
  options.seed = 4;
  return options;
}

TEST(SynthesizeCommunityScene, SameSeedSameBytes) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions options = SmallScene();
  options.outlier_match_ratio = 0.1;
  options.num_false_pairs = 5;
  for (const std::string name : {"a.db", "b.db", "c.db"}) {
    if (name == "c.db") {
      options.seed += 1;
    }
    Database database(JoinPaths(test_dir, name));
    SyntheticScene scene;
    SynthesizeCommunityScene(options, &scene, &database);
  }
  const std::string a = ReadBytes(JoinPaths(test_dir, "a.db"));
  EXPECT_GT(a.size(), 100000);
  EXPECT_EQ(a, ReadBytes(JoinPaths(test_dir, "b.db")));
  EXPECT_NE(a, ReadBytes(JoinPaths(test_dir, "c.db")));
}

TEST(SynthesizeCommunityScene, DatabaseMatchesGroundTruth) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions options = SmallScene();
  options.outlier_match_ratio = 0.1;
  options.num_false_pairs = 6;
  Database database(JoinPaths(test_dir, "database.db"));
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, &database);
  const Reconstruction& truth = scene.ground_truth;

  // Images: clusters and walkways as asked.
  ASSERT_EQ(truth.NumRegImages(), 3 * 12 + 3 * 10);
  EXPECT_EQ(database.NumImages(), truth.NumRegImages());
  std::map<int, int> cluster_sizes;
  for (const auto& image_and_cluster : scene.image_cluster) {
    ++cluster_sizes[image_and_cluster.second];
  }
  EXPECT_EQ(cluster_sizes,
            (std::map<int, int>{{-1, 30}, {0, 12}, {1, 12}, {2, 12}}));

  // Keypoints are the ground truth's points2D, which reproject within the
  // noise.
  for (const image_t image_id : truth.RegImageIds()) {
    const Image& image = truth.Image(image_id);
    const FeatureKeypoints keypoints = database.ReadKeypoints(image_id);
    ASSERT_EQ(keypoints.size(), image.NumPoints2D());
    EXPECT_EQ(database.ReadImage(image_id).Name(), image.Name());
    for (point2D_t idx = 0; idx < keypoints.size(); ++idx) {
      EXPECT_NEAR(keypoints[idx].x, image.Point2D(idx).xy.x(), 1e-3);
    }
  }
  Reconstruction reprojected = truth;
  reprojected.UpdatePoint3DErrors();
  EXPECT_LT(reprojected.ComputeMeanReprojectionError(), 1.0);
  EXPECT_GT(reprojected.ComputeMeanReprojectionError(), 0.3);

  // Verified pairs: true matches plus ~10% wrong ones; false pairs share
  // no point at all.
  std::vector<image_pair_t> pair_ids;
  std::vector<TwoViewGeometry> two_view_geometries;
  database.ReadTwoViewGeometries(&pair_ids, &two_view_geometries);
  ASSERT_EQ(static_cast<int>(pair_ids.size()),
            scene.num_verified_pairs + scene.num_false_pairs);
  EXPECT_EQ(scene.num_false_pairs, 6);
  int num_false = 0;
  for (size_t i = 0; i < pair_ids.size(); ++i) {
    const auto image_pair = Database::PairIdToImagePair(pair_ids[i]);
    const Image& image1 = truth.Image(image_pair.first);
    const Image& image2 = truth.Image(image_pair.second);
    int num_true = 0;
    for (const FeatureMatch& match : two_view_geometries[i].inlier_matches) {
      const Point2D& point1 = image1.Point2D(match.point2D_idx1);
      const Point2D& point2 = image2.Point2D(match.point2D_idx2);
      num_true += point1.HasPoint3D() && point1.point3D_id == point2.point3D_id;
    }
    const int num_matches =
        static_cast<int>(two_view_geometries[i].inlier_matches.size());
    if (num_true == 0) {
      ++num_false;
      EXPECT_EQ(num_matches, options.false_pair_num_matches);
    } else {
      EXPECT_GE(num_true, options.min_num_inliers);
      EXPECT_NEAR(num_matches, 1.1 * num_true, 1.0);
    }
  }
  EXPECT_EQ(num_false, 6);
}

TEST(SynthesizeCommunityScene, ClustersAreDenseWalkwaysSparse) {
  SyntheticScene scene;
  SynthesizeCommunityScene(SmallScene(), &scene, /*database=*/nullptr);
  // Count pairs sharing at least 15 points within clusters and between
  // the rest.
  std::map<std::pair<image_t, image_t>, int> shared;
  for (const auto& point3D : scene.ground_truth.Points3D()) {
    const auto& elements = point3D.second.track.Elements();
    for (size_t i = 0; i < elements.size(); ++i) {
      for (size_t j = 0; j < i; ++j) {
        ++shared[std::minmax(elements[i].image_id, elements[j].image_id)];
      }
    }
  }
  int num_intra = 0;
  for (const auto& pair_and_count : shared) {
    const int cluster1 = scene.image_cluster.at(pair_and_count.first.first);
    const int cluster2 = scene.image_cluster.at(pair_and_count.first.second);
    if (pair_and_count.second >= 15 && cluster1 >= 0 && cluster1 == cluster2) {
      ++num_intra;
    }
  }
  // Most pairs within a cluster see the landmark together.
  EXPECT_GT(num_intra, 0.5 * 3 * (12 * 11 / 2));
  // No cluster image sees another cluster's landmark.
  for (const auto& pair_and_count : shared) {
    const int cluster1 = scene.image_cluster.at(pair_and_count.first.first);
    const int cluster2 = scene.image_cluster.at(pair_and_count.first.second);
    if (cluster1 >= 0 && cluster2 >= 0) {
      EXPECT_EQ(cluster1, cluster2);
    }
  }
}

TEST(SynthesizeCommunityScene, FocalLengthsOffTheNominalValue) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions options = SmallScene();
  options.single_camera = false;
  options.focal_length_noise = 0.05;
  Database database(JoinPaths(test_dir, "database.db"));
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, &database);
  // The database holds the nominal focal length as a prior; the truth, one
  // camera per image, spreads around it by about 5%.
  double sum_sq = 0;
  for (const Camera& camera : database.ReadAllCameras()) {
    EXPECT_TRUE(camera.has_prior_focal_length);
    EXPECT_EQ(camera.FocalLength(), options.focal_length);
    const double relative =
        scene.ground_truth.Camera(camera.camera_id).FocalLength() /
            options.focal_length -
        1;
    sum_sq += relative * relative;
  }
  ASSERT_EQ(database.NumCameras(), scene.ground_truth.NumRegImages());
  const double spread = std::sqrt(sum_sq / database.NumCameras());
  EXPECT_GT(spread, 0.03);
  EXPECT_LT(spread, 0.08);
  // Keypoints are the projections by the true cameras.
  Reconstruction reprojected = scene.ground_truth;
  reprojected.UpdatePoint3DErrors();
  EXPECT_LT(reprojected.ComputeMeanReprojectionError(), 1.0);
}

TEST(SynthesizeCommunityScene, RepeatedStructurePairsAgreeWithAStackedTower) {
  const std::string test_dir = CreateTestFolder();
  SyntheticSceneOptions options = SmallScene();
  options.num_clusters = 2;
  options.num_images_per_link = 0;
  options.num_repeated_structure_pairs = 8;
  Database database(JoinPaths(test_dir, "database.db"));
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, &database);
  const Reconstruction& truth = scene.ground_truth;
  EXPECT_EQ(scene.num_repeated_structure_pairs, 8);

  std::vector<image_pair_t> pair_ids;
  std::vector<TwoViewGeometry> two_view_geometries;
  database.ReadTwoViewGeometries(&pair_ids, &two_view_geometries);
  int num_cross = 0;
  for (size_t i = 0; i < pair_ids.size(); ++i) {
    image_t image_id1;
    image_t image_id2;
    std::tie(image_id1, image_id2) = Database::PairIdToImagePair(pair_ids[i]);
    const int cluster1 = scene.image_cluster.at(image_id1);
    const int cluster2 = scene.image_cluster.at(image_id2);
    if (cluster1 == cluster2) {
      continue;
    }
    ++num_cross;
    // Every match joins a point of one tower with the same point of the
    // other: shifted by the towers' offset, the two 3D points coincide.
    const Image& image1 = truth.Image(image_id1);
    const Image& image2 = truth.Image(image_id2);
    const auto& matches = two_view_geometries[i].inlier_matches;
    ASSERT_GE(static_cast<int>(matches.size()), options.min_num_inliers);
    // (The ground truth keeps only points seen twice in their own cluster;
    // matches of the others cannot be checked.)
    const Rigid3d cam2_from_cam1 = two_view_geometries[i].cam2_from_cam1;
    int num_checked = 0;
    for (const FeatureMatch& match : matches) {
      const Point2D& point1 = image1.Point2D(match.point2D_idx1);
      const Point2D& point2 = image2.Point2D(match.point2D_idx2);
      if (!point1.HasPoint3D() || !point2.HasPoint3D()) {
        continue;
      }
      const Eigen::Vector3d& xyz1 = truth.Point3D(point1.point3D_id).xyz;
      const Eigen::Vector3d& xyz2 = truth.Point3D(point2.point3D_id).xyz;
      EXPECT_NEAR((xyz2 - xyz1).norm(), options.landmark_spacing, 1e-6);
      EXPECT_NEAR((xyz2 - xyz1).z(), 0, 1e-6);
      // The stored relative pose is the one of the stacked towers.
      EXPECT_LT((cam2_from_cam1 * (image1.CamFromWorld() * xyz1) -
                 image2.CamFromWorld() * xyz2)
                    .norm(),
                1e-6);
      ++num_checked;
    }
    EXPECT_GE(num_checked, 5);
  }
  EXPECT_EQ(num_cross, 8);
}

TEST(SyntheticSceneOptions, Check) {
  SyntheticSceneOptions options;
  EXPECT_TRUE(options.Check());
  options.num_clusters = 0;
  EXPECT_FALSE(options.Check());
}

}  // namespace
}  // namespace colmap
