#include "colmap_ext/testing/matched_pair_verification.h"

#include "colmap_ext/testing/testing.h"

#include "colmap/geometry/essential_matrix.h"
#include "colmap/geometry/pose.h"
#include "colmap/math/random.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// Two views of random points in front of both (the ground truth built by
// hand), their keypoints and raw matches: `num_true` true correspondences
// and `num_wrong` random ones, written to a database with no two-view
// geometry. A third image shares only a few matches with the first.
struct TwoViews {
  Rigid3d cam2_from_cam1;
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  image_t image_id3 = kInvalidImageId;
  int num_true = 0;
};

TwoViews WriteTwoViews(const int num_true,
                       const int num_wrong,
                       Database* database) {
  SetPRNGSeed(3);
  Camera camera = Camera::CreateFromModelName(
      kInvalidCameraId, "SIMPLE_RADIAL", 800, 1024, 768);
  camera.has_prior_focal_length = true;
  camera.camera_id = database->WriteCamera(camera);

  TwoViews views;
  views.num_true = num_true;
  views.cam2_from_cam1 = Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY())),
      Eigen::Vector3d(-1, 0.1, 0.05));
  const std::vector<Rigid3d> cams_from_world = {
      Rigid3d(), views.cam2_from_cam1, Rigid3d()};
  std::vector<FeatureKeypoints> keypoints(3);
  for (int i = 0; i < num_true + num_wrong; ++i) {
    const Eigen::Vector3d xyz(RandomUniformReal(-3.0, 3.0),
                              RandomUniformReal(-2.0, 2.0),
                              RandomUniformReal(6.0, 12.0));
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector2d xy = *camera.ImgFromCam(cams_from_world[k] * xyz);
      keypoints[k].emplace_back(static_cast<float>(xy.x()),
                                static_cast<float>(xy.y()));
    }
  }
  for (int i = 0; i < 10; ++i) {
    keypoints[2].emplace_back(keypoints[0][i]);
  }

  std::vector<image_t> image_ids;
  for (int k = 0; k < 3; ++k) {
    Image image;
    image.SetName("image" + std::to_string(k) + ".jpg");
    image.SetCameraId(camera.camera_id);
    image_ids.push_back(database->WriteImage(image));
    database->WriteKeypoints(image_ids.back(), keypoints[k]);
  }
  views.image_id1 = image_ids[0];
  views.image_id2 = image_ids[1];
  views.image_id3 = image_ids[2];

  // True matches i-i; wrong ones join keypoint i of the first image with
  // another point's keypoint in the second.
  FeatureMatches matches;
  for (int i = 0; i < num_true; ++i) {
    matches.emplace_back(i, i);
  }
  for (int i = 0; i < num_wrong; ++i) {
    matches.emplace_back(num_true + i, num_true + (i + 7) % num_wrong);
  }
  database->WriteMatches(image_ids[0], image_ids[1], matches);
  FeatureMatches few;
  for (int i = 0; i < 10; ++i) {
    few.emplace_back(i, i);
  }
  database->WriteMatches(image_ids[0], image_ids[2], few);
  return views;
}

TEST(VerifyMatchedPairs, KeepsTheTrueMatchesRejectsTheWrongStoresNoPose) {
  const std::shared_ptr<Database> database = Database::Open(
      std::filesystem::path(CreateTestFolder()) / "database.db");
  const TwoViews views =
      WriteTwoViews(/*num_true=*/150, /*num_wrong=*/50, database.get());

  const MatchedPairVerificationStats stats = VerifyMatchedPairs(
      TwoViewGeometryOptions(), /*seed=*/1, /*num_threads=*/2, database.get());
  EXPECT_EQ(stats.num_matched_pairs, 2);
  EXPECT_EQ(stats.num_verified_pairs, 1);
  EXPECT_EQ(stats.num_matches, 210);

  const TwoViewGeometry geometry =
      database->ReadTwoViewGeometry(views.image_id1, views.image_id2);
  EXPECT_EQ(geometry.config, TwoViewGeometry::CALIBRATED);
  // As COLMAP's matchers store them: no relative pose.
  EXPECT_FALSE(geometry.cam2_from_cam1.has_value());
  int num_true = 0;
  for (const FeatureMatch& match : geometry.inlier_matches) {
    num_true += match.point2D_idx1 == match.point2D_idx2;
  }
  EXPECT_GE(num_true, 145);
  EXPECT_LE(static_cast<int>(geometry.inlier_matches.size()) - num_true, 2);
  EXPECT_EQ(stats.num_inlier_matches, geometry.inlier_matches.size());
  // The estimated essential matrix is the true one's, up to scale.
  ASSERT_TRUE(geometry.E.has_value());
  const Eigen::Matrix3d true_E = EssentialMatrixFromPose(views.cam2_from_cam1);
  const Eigen::Matrix3d E = geometry.E->normalized();
  EXPECT_LT(std::min((E - true_E.normalized()).norm(),
                     (E + true_E.normalized()).norm()),
            0.05);

  // Too few matches to verify: an empty geometry, as the verifier writes.
  ASSERT_TRUE(
      database->ExistsTwoViewGeometry(views.image_id1, views.image_id3));
  const TwoViewGeometry few =
      database->ReadTwoViewGeometry(views.image_id1, views.image_id3);
  EXPECT_EQ(few.config, TwoViewGeometry::UNDEFINED);
  EXPECT_TRUE(few.inlier_matches.empty());

  // Pairs that have a geometry are left as they are.
  EXPECT_EQ(VerifyMatchedPairs(TwoViewGeometryOptions(),
                               /*seed=*/1,
                               /*num_threads=*/2,
                               database.get())
                .num_matched_pairs,
            0);
}

// Views of random points from cameras along a line, keypoints with noise,
// every pair matched on all its points' keypoints, half the matches wrong.
void WriteNoisyViews(const int num_views, Database* database) {
  SetPRNGSeed(11);
  Camera camera = Camera::CreateFromModelName(
      kInvalidCameraId, "SIMPLE_RADIAL", 800, 1024, 768);
  camera.has_prior_focal_length = true;
  camera.camera_id = database->WriteCamera(camera);
  constexpr int kNumPoints = 80;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < kNumPoints; ++i) {
    points.emplace_back(RandomUniformReal(-3.0, 3.0),
                        RandomUniformReal(-2.0, 2.0),
                        RandomUniformReal(8.0, 12.0));
  }
  std::vector<image_t> image_ids;
  for (int k = 0; k < num_views; ++k) {
    const Rigid3d cam_from_world(Eigen::Quaterniond::Identity(),
                                 Eigen::Vector3d(-0.5 * k, 0, 0));
    FeatureKeypoints keypoints;
    for (const Eigen::Vector3d& xyz : points) {
      const Eigen::Vector2d xy = *camera.ImgFromCam(cam_from_world * xyz) +
                                 Eigen::Vector2d(RandomGaussian(0.0, 1.5),
                                                 RandomGaussian(0.0, 1.5));
      keypoints.emplace_back(static_cast<float>(xy.x()),
                             static_cast<float>(xy.y()));
    }
    Image image;
    image.SetName("image" + std::to_string(k) + ".jpg");
    image.SetCameraId(camera.camera_id);
    image_ids.push_back(database->WriteImage(image));
    database->WriteKeypoints(image_ids.back(), keypoints);
  }
  for (int k1 = 0; k1 < num_views; ++k1) {
    for (int k2 = k1 + 1; k2 < num_views; ++k2) {
      FeatureMatches matches;
      for (int i = 0; i < kNumPoints; ++i) {
        matches.emplace_back(
            i, i < kNumPoints / 2 ? i : kNumPoints / 2 + (i + k2) % 40);
      }
      database->WriteMatches(image_ids[k1], image_ids[k2], matches);
    }
  }
}

TEST(VerifyMatchedPairs, SameSeedSameGeometriesWhateverTheThreads) {
  const std::filesystem::path test_dir = CreateTestFolder();
  std::vector<std::vector<std::pair<image_pair_t, TwoViewGeometry>>>
      geometries;
  for (const int num_threads : {1, 2}) {
    const std::shared_ptr<Database> database = Database::Open(
        test_dir / ("database" + std::to_string(num_threads) + ".db"));
    WriteNoisyViews(/*num_views=*/8, database.get());
    VerifyMatchedPairs(
        TwoViewGeometryOptions(), /*seed=*/5, num_threads, database.get());
    geometries.push_back(database->ReadTwoViewGeometries());
  }
  ASSERT_EQ(geometries[0].size(), 28);
  ASSERT_EQ(geometries[1].size(), 28);
  for (size_t i = 0; i < geometries[0].size(); ++i) {
    EXPECT_EQ(geometries[0][i].first, geometries[1][i].first);
    const TwoViewGeometry& a = geometries[0][i].second;
    const TwoViewGeometry& b = geometries[1][i].second;
    EXPECT_EQ(a.config, b.config);
    ASSERT_EQ(a.inlier_matches.size(), b.inlier_matches.size());
    for (size_t j = 0; j < a.inlier_matches.size(); ++j) {
      EXPECT_EQ(a.inlier_matches[j].point2D_idx1,
                b.inlier_matches[j].point2D_idx1);
      EXPECT_EQ(a.inlier_matches[j].point2D_idx2,
                b.inlier_matches[j].point2D_idx2);
    }
    if (a.E.has_value() && b.E.has_value()) {
      EXPECT_EQ(*a.E, *b.E);
    }
  }
}

}  // namespace
}  // namespace colmap
