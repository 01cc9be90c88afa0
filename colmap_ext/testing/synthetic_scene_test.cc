#include "colmap_ext/testing/synthetic_scene.h"

#include "colmap_ext/testing/testing.h"

#include "colmap/geometry/essential_matrix.h"
#include "colmap/geometry/pose.h"
#include "colmap/math/math.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

namespace colmap {
namespace {

std::string ReadBytes(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file),
                     std::istreambuf_iterator<char>());
}

// The scene written to a new database in the test's own folder.
std::shared_ptr<Database> SynthesizeInTestFolder(
    const SyntheticSceneOptions& options, SyntheticScene* scene) {
  const std::shared_ptr<Database> database = Database::Open(
      std::filesystem::path(CreateTestFolder()) / "database.db");
  SynthesizeCommunityScene(options, scene, database.get());
  return database;
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
  const std::filesystem::path test_dir = CreateTestFolder();
  SyntheticSceneOptions options = SmallScene();
  options.num_false_pairs = 5;
  options.num_repeated_texture_pairs = 5;
  for (const std::string name : {"a.db", "b.db", "c.db"}) {
    if (name == "c.db") {
      options.seed += 1;
    }
    const std::shared_ptr<Database> database = Database::Open(test_dir / name);
    SyntheticScene scene;
    SynthesizeCommunityScene(options, &scene, database.get());
  }
  const std::string a = ReadBytes(test_dir / "a.db");
  EXPECT_GT(a.size(), 100000);
  EXPECT_EQ(a, ReadBytes(test_dir / "b.db"));
  EXPECT_NE(a, ReadBytes(test_dir / "c.db"));
}

// Whether a match joins two observations of the same point.
bool IsTrueMatch(const Reconstruction& truth,
                 const image_t image_id1,
                 const image_t image_id2,
                 const FeatureMatch& match) {
  const Point2D& point1 = truth.Image(image_id1).Point2D(match.point2D_idx1);
  const Point2D& point2 = truth.Image(image_id2).Point2D(match.point2D_idx2);
  return point1.HasPoint3D() && point1.point3D_id == point2.point3D_id;
}

TEST(SynthesizeCommunityScene, DatabaseMatchesGroundTruth) {
  SyntheticSceneOptions options = SmallScene();
  options.num_false_pairs = 6;
  SyntheticScene scene;
  const std::shared_ptr<Database> database =
      SynthesizeInTestFolder(options, &scene);
  const Reconstruction& truth = scene.ground_truth;

  // Images: clusters and walkways as asked.
  ASSERT_EQ(truth.NumRegImages(), 3 * 12 + 3 * 10);
  EXPECT_EQ(database->NumImages(), truth.NumRegImages());

  // As the feature extractor writes them: the camera in a rig of its own,
  // every image in a frame of its own; the ground truth's are the same.
  EXPECT_EQ(database->NumCameras(), 1);
  EXPECT_EQ(database->NumRigs(), 1);
  const Rig rig = database->ReadAllRigs().at(0);
  EXPECT_EQ(rig.NumSensors(), 1);
  EXPECT_EQ(rig.RefSensorId(), database->ReadAllCameras().at(0).SensorId());
  EXPECT_EQ(truth.Rig(rig.RigId()).RefSensorId(), rig.RefSensorId());
  ASSERT_EQ(database->NumFrames(), truth.NumRegFrames());
  for (const Frame& frame : database->ReadAllFrames()) {
    EXPECT_EQ(frame.RigId(), rig.RigId());
    ASSERT_EQ(frame.NumDataIds(), 1);
    const data_t& data_id = *frame.DataIds().begin();
    const Image& image = truth.Image(static_cast<image_t>(data_id.id));
    EXPECT_EQ(image.FrameId(), frame.FrameId());
    EXPECT_EQ(image.DataId(), data_id);
    EXPECT_TRUE(truth.Frame(frame.FrameId()).HasPose());
  }
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
    const FeatureKeypoints keypoints = database->ReadKeypoints(image_id);
    ASSERT_EQ(keypoints.size(), image.NumPoints2D());
    EXPECT_EQ(database->ReadImage(image_id).Name(), image.Name());
    for (point2D_t idx = 0; idx < keypoints.size(); ++idx) {
      EXPECT_NEAR(keypoints[idx].x, image.Point2D(idx).xy.x(), 1e-3);
    }
  }
  Reconstruction reprojected = truth;
  reprojected.UpdatePoint3DErrors();
  EXPECT_LT(reprojected.ComputeMeanReprojectionError(), 1.0);
  EXPECT_GT(reprojected.ComputeMeanReprojectionError(), 0.3);

  // Raw matches: every pair sharing points, a quarter of its matches
  // wrong; the chance pairs share no point at all.
  const std::vector<std::pair<image_pair_t, FeatureMatches>> all_matches =
      database->ReadAllMatches();
  ASSERT_EQ(static_cast<int>(all_matches.size()), scene.num_matched_pairs);
  EXPECT_EQ(scene.num_false_pairs, 6);
  std::map<image_pair_t, int> num_true_raw;
  size_t num_raw = 0;
  size_t num_wrong_raw = 0;
  int num_chance = 0;
  for (const auto& [pair_id, matches] : all_matches) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    int num_true = 0;
    for (const FeatureMatch& match : matches) {
      num_true += IsTrueMatch(truth, image_id1, image_id2, match);
    }
    num_true_raw[pair_id] = num_true;
    if (num_true == 0) {
      ++num_chance;
      EXPECT_EQ(matches.size(), options.false_pair_num_matches);
      continue;
    }
    EXPECT_GE(num_true, options.min_num_shared_points);
    num_raw += matches.size();
    num_wrong_raw += matches.size() - num_true;
  }
  EXPECT_EQ(num_chance, 6);
  EXPECT_NEAR(static_cast<double>(num_wrong_raw) / num_raw,
              options.wrong_match_fraction,
              0.01);

  // Two-view geometries, as COLMAP's verification writes them: one for
  // every matched pair, no relative pose, the true matches kept and the
  // random wrong ones rejected; the chance pairs not verified.
  size_t num_inliers = 0;
  size_t num_true_inliers = 0;
  size_t num_true_in_verified = 0;
  int num_verified = 0;
  for (const auto& [pair_id, matches] : all_matches) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    ASSERT_TRUE(database->ExistsTwoViewGeometry(image_id1, image_id2));
    const TwoViewGeometry two_view_geometry =
        database->ReadTwoViewGeometry(image_id1, image_id2);
    EXPECT_FALSE(two_view_geometry.cam2_from_cam1.has_value());
    if (two_view_geometry.inlier_matches.empty()) {
      EXPECT_EQ(two_view_geometry.config, TwoViewGeometry::UNDEFINED);
      continue;
    }
    EXPECT_GT(num_true_raw.at(pair_id), 0);
    ++num_verified;
    for (const FeatureMatch& match : two_view_geometry.inlier_matches) {
      num_true_inliers += IsTrueMatch(truth, image_id1, image_id2, match);
    }
    num_inliers += two_view_geometry.inlier_matches.size();
    num_true_in_verified += num_true_raw.at(pair_id);
  }
  EXPECT_EQ(num_verified, scene.num_verified_pairs);
  EXPECT_EQ(num_inliers, scene.num_inlier_matches);
  EXPECT_GT(num_verified, 0.9 * (scene.num_matched_pairs - num_chance));
  EXPECT_GT(num_true_inliers, 0.95 * num_true_in_verified);
  // Of the wrong matches, those near their epipolar line survive.
  const double num_wrong_inliers =
      static_cast<double>(num_inliers - num_true_inliers);
  EXPECT_LT(num_wrong_inliers, 0.5 * num_wrong_raw);
  EXPECT_GT(num_wrong_inliers, 0.05 * num_wrong_raw);
  // The verification rejected at least a tenth of the raw matches.
  EXPECT_LT(num_inliers, 0.9 * scene.num_raw_matches);
}

TEST(SynthesizeCommunityScene, ExactGeometriesForUnitTests) {
  SyntheticSceneOptions options = SmallScene();
  options.exact_two_view_geometries = true;
  options.wrong_match_fraction = 0;
  SyntheticScene scene;
  const std::shared_ptr<Database> database =
      SynthesizeInTestFolder(options, &scene);
  const Reconstruction& truth = scene.ground_truth;
  const std::vector<std::pair<image_pair_t, TwoViewGeometry>>
      two_view_geometries = database->ReadTwoViewGeometries();
  ASSERT_EQ(static_cast<int>(two_view_geometries.size()),
            scene.num_matched_pairs);
  EXPECT_EQ(scene.num_verified_pairs, scene.num_matched_pairs);
  for (const auto& [pair_id, two_view_geometry] : two_view_geometries) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    for (const FeatureMatch& match : two_view_geometry.inlier_matches) {
      EXPECT_TRUE(IsTrueMatch(truth, image_id1, image_id2, match));
    }
    ASSERT_TRUE(two_view_geometry.cam2_from_cam1.has_value());
    const Rigid3d true_cam2_from_cam1 =
        truth.Image(image_id2).CamFromWorld() *
        Inverse(truth.Image(image_id1).CamFromWorld());
    EXPECT_LT((two_view_geometry.cam2_from_cam1->ToMatrix() -
               true_cam2_from_cam1.ToMatrix())
                  .norm(),
              1e-9);
  }
}

// The wrong raw matches of the pairs sharing points: random keypoints, or
// keypoints that satisfy the pair's epipolar geometry, as repeated texture
// along the line makes them. Returns the largest and the median epipolar
// distance (pixels, in the second image) of the wrong matches, and the
// share of them that the verification kept.
struct WrongMatches {
  double max_distance = 0;
  double median_distance = 0;
  double kept = 0;
};

WrongMatches WrongMatchesOf(const double epipolar_wrong_match_share) {
  SyntheticSceneOptions options = SmallScene();
  options.epipolar_wrong_match_share = epipolar_wrong_match_share;
  SyntheticScene scene;
  const std::shared_ptr<Database> database =
      SynthesizeInTestFolder(options, &scene);
  const Reconstruction& truth = scene.ground_truth;
  std::vector<double> distances;
  int num_true = 0;
  for (const auto& [pair_id, matches] : database->ReadAllMatches()) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    const Image& image1 = truth.Image(image_id1);
    const Image& image2 = truth.Image(image_id2);
    const Rigid3d cam2_from_cam1 =
        image2.CamFromWorld() * Inverse(image1.CamFromWorld());
    const Eigen::Matrix3d F = FundamentalFromEssentialMatrix(
        truth.Camera(image2.CameraId()).CalibrationMatrix(),
        EssentialMatrixFromPose(cam2_from_cam1),
        truth.Camera(image1.CameraId()).CalibrationMatrix());
    for (const FeatureMatch& match : matches) {
      if (IsTrueMatch(truth, image_id1, image_id2, match)) {
        ++num_true;
        continue;
      }
      const Eigen::Vector3d line = F * image1.Point2D(match.point2D_idx1).xy.homogeneous();
      distances.push_back(
          std::abs(line.dot(image2.Point2D(match.point2D_idx2).xy.homogeneous())) /
          line.head<2>().norm());
    }
  }
  EXPECT_NEAR(distances.size(), num_true / 3.0, 0.02 * num_true);
  size_t num_wrong_inliers = 0;
  for (const auto& [pair_id, two_view_geometry] :
       database->ReadTwoViewGeometries()) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    for (const FeatureMatch& match : two_view_geometry.inlier_matches) {
      num_wrong_inliers += !IsTrueMatch(truth, image_id1, image_id2, match);
    }
  }
  std::sort(distances.begin(), distances.end());
  return {distances.back(),
          distances[distances.size() / 2],
          static_cast<double>(num_wrong_inliers) / distances.size()};
}

TEST(SynthesizeCommunityScene, EpipolarWrongMatchesSurviveTheVerification) {
  const WrongMatches epipolar = WrongMatchesOf(1.0);
  EXPECT_LE(epipolar.max_distance, 4.0 + 1e-3);
  EXPECT_GT(epipolar.kept, 0.5);
  // Most random ones are rejected; a few lie near the line by chance or fit
  // the looser geometry of a planar view.
  const WrongMatches random = WrongMatchesOf(0.0);
  EXPECT_GT(random.median_distance, 20.0);
  EXPECT_LT(random.kept, 0.15);
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
  SyntheticSceneOptions options = SmallScene();
  options.single_camera = false;
  options.focal_length_noise = 0.05;
  SyntheticScene scene;
  const std::shared_ptr<Database> database =
      SynthesizeInTestFolder(options, &scene);
  // The database holds the nominal focal length as a prior; the truth, one
  // camera per image, spreads around it by about 5%.
  double sum_sq = 0;
  for (const Camera& camera : database->ReadAllCameras()) {
    EXPECT_TRUE(camera.has_prior_focal_length);
    EXPECT_EQ(camera.FocalLength(), options.focal_length);
    const double relative =
        scene.ground_truth.Camera(camera.camera_id).FocalLength() /
            options.focal_length -
        1;
    sum_sq += relative * relative;
  }
  ASSERT_EQ(database->NumCameras(), scene.ground_truth.NumRegImages());
  // One rig per camera.
  EXPECT_EQ(database->NumRigs(), database->NumCameras());
  EXPECT_EQ(scene.ground_truth.NumRigs(), database->NumCameras());
  const double spread = std::sqrt(sum_sq / database->NumCameras());
  EXPECT_GT(spread, 0.03);
  EXPECT_LT(spread, 0.08);
  // Keypoints are the projections by the true cameras.
  Reconstruction reprojected = scene.ground_truth;
  reprojected.UpdatePoint3DErrors();
  EXPECT_LT(reprojected.ComputeMeanReprojectionError(), 1.0);
}

// The pairs matched on repeated structure or texture of a scene: the pairs
// between images of different landmarks (towers) or of different walls
// (posters) that share no point. For each, checks that its matches join
// points at the same place of two copies of the pattern (`are_copies`):
// the fraction of its raw matches that do, at least
// that of true matches, and the verification's outcome.
struct RepeatedPairs {
  int num_pairs = 0;
  int num_verified = 0;
  int num_planar = 0;
};

RepeatedPairs CheckRepeatedPairs(
    const SyntheticSceneOptions& options,
    const std::function<bool(const Eigen::Vector3d&, const Eigen::Vector3d&)>&
        are_copies) {
  SyntheticScene scene;
  const std::shared_ptr<Database> database =
      SynthesizeInTestFolder(options, &scene);
  const Reconstruction& truth = scene.ground_truth;
  RepeatedPairs repeated;
  for (const auto& [pair_id, matches] : database->ReadAllMatches()) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    const Image& image1 = truth.Image(image_id1);
    const Image& image2 = truth.Image(image_id2);
    int num_true = 0;
    int num_pattern = 0;
    for (const FeatureMatch& match : matches) {
      const Point2D& point1 = image1.Point2D(match.point2D_idx1);
      const Point2D& point2 = image2.Point2D(match.point2D_idx2);
      if (!point1.HasPoint3D() || !point2.HasPoint3D()) {
        continue;
      }
      const Eigen::Vector3d& xyz1 = truth.Point3D(point1.point3D_id).xyz;
      const Eigen::Vector3d& xyz2 = truth.Point3D(point2.point3D_id).xyz;
      num_true += point1.point3D_id == point2.point3D_id;
      num_pattern += are_copies(xyz1, xyz2);
    }
    if (num_true > 0) {
      continue;
    }
    const TwoViewGeometry two_view_geometry =
        database->ReadTwoViewGeometry(image_id1, image_id2);
    if (static_cast<int>(matches.size()) == options.false_pair_num_matches &&
        num_pattern == 0) {
      continue;  // Matched by chance.
    }
    ++repeated.num_pairs;
    // (The ground truth keeps only the points seen twice: the matches of the
    // others cannot be checked.)
    EXPECT_GE(num_pattern, 0.5 * (1 - options.wrong_match_fraction) *
                               options.min_num_shared_points);
    EXPECT_GE(num_pattern, 0.5 * (1 - options.wrong_match_fraction) * matches.size());
    if (!two_view_geometry.inlier_matches.empty()) {
      ++repeated.num_verified;
      repeated.num_planar +=
          two_view_geometry.config == TwoViewGeometry::PLANAR ||
          two_view_geometry.config == TwoViewGeometry::PLANAR_OR_PANORAMIC;
    }
    if (options.exact_two_view_geometries) {
      // The stored relative pose stacks one copy on the other.
      EXPECT_EQ(two_view_geometry.inlier_matches.size(), matches.size());
      EXPECT_TRUE(two_view_geometry.cam2_from_cam1.has_value());
      if (!two_view_geometry.cam2_from_cam1.has_value()) {
        continue;
      }
      for (const FeatureMatch& match : matches) {
        const Point2D& point1 = image1.Point2D(match.point2D_idx1);
        const Point2D& point2 = image2.Point2D(match.point2D_idx2);
        if (point1.HasPoint3D() && point2.HasPoint3D() &&
            are_copies(truth.Point3D(point1.point3D_id).xyz,
                       truth.Point3D(point2.point3D_id).xyz)) {
          EXPECT_LT((*two_view_geometry.cam2_from_cam1 *
                         (image1.CamFromWorld() *
                          truth.Point3D(point1.point3D_id).xyz) -
                     image2.CamFromWorld() *
                         truth.Point3D(point2.point3D_id).xyz)
                        .norm(),
                    1e-6);
        }
      }
    }
  }
  return repeated;
}

TEST(SynthesizeCommunityScene, RepeatedStructurePairsAgreeWithAStackedTower) {
  SyntheticSceneOptions options = SmallScene();
  options.num_clusters = 2;
  options.num_images_per_link = 0;
  options.num_repeated_structure_pairs = 8;
  // The second tower is the first shifted by the landmarks' spacing.
  const auto stacked = [&](const Eigen::Vector3d& xyz1,
                           const Eigen::Vector3d& xyz2) {
    return std::abs((xyz2 - xyz1).norm() - options.landmark_spacing) < 1e-6 &&
           std::abs(xyz2.z() - xyz1.z()) < 1e-6;
  };
  const RepeatedPairs verified = CheckRepeatedPairs(options, stacked);
  EXPECT_EQ(verified.num_pairs, 8);
  // One rigid motion explains the matches: they pass the verification.
  EXPECT_GE(verified.num_verified, 6);
  options.exact_two_view_geometries = true;
  EXPECT_EQ(CheckRepeatedPairs(options, stacked).num_pairs, 8);
}

TEST(SynthesizeCommunityScene, RepeatedTexturePairsAgreeWithOneHomography) {
  SyntheticSceneOptions options = SmallScene();
  options.num_images_per_link = 16;
  // The poster has the wall's density: enough points on it to be matched.
  options.num_points_per_link = 1200;
  options.num_repeated_texture_pairs = 6;
  // Copies of the poster on two walls: points at the same height (no two
  // points of the walls' own texture are), a wall apart.
  const auto copies = [](const Eigen::Vector3d& xyz1,
                         const Eigen::Vector3d& xyz2) {
    return std::abs(xyz2.z() - xyz1.z()) < 1e-9 &&
           (xyz2 - xyz1).head<2>().norm() > 1;
  };
  const RepeatedPairs verified = CheckRepeatedPairs(options, copies);
  EXPECT_EQ(verified.num_pairs, 6);
  // One plane's homography explains the matches: they pass the
  // verification as planar.
  EXPECT_GE(verified.num_verified, 5);
  EXPECT_GE(verified.num_planar, verified.num_verified - 1);
}

TEST(SynthesizeCommunityScene, StereoRigAsRigConfiguratorWritesIt) {
  SyntheticSceneOptions options = SmallScene();
  options.num_rig_cameras = 2;
  options.rig_baseline = 0.4;
  options.rig_yaw_deg = 3.0;
  SyntheticScene scene;
  const std::shared_ptr<Database> database =
      SynthesizeInTestFolder(options, &scene);
  const Reconstruction& truth = scene.ground_truth;

  // Every camera position is a snapshot of the rig: two images.
  const int num_positions = 3 * 12 + 3 * 10;
  ASSERT_EQ(truth.NumRegImages(), 2 * num_positions);
  EXPECT_EQ(database->NumImages(), truth.NumRegImages());
  EXPECT_EQ(truth.NumRegFrames(), num_positions);

  // One rig of two cameras, the second at its true pose in the rig: 0.4 m
  // to the right of the first, turned right by 3 degrees.
  EXPECT_EQ(database->NumCameras(), 2);
  ASSERT_EQ(database->NumRigs(), 1);
  const Rig rig = database->ReadAllRigs().at(0);
  ASSERT_EQ(rig.NumSensors(), 2);
  ASSERT_EQ(rig.NonRefSensors().size(), 1);
  const sensor_t ref_sensor_id = rig.RefSensorId();
  const auto& [sensor_id, sensor_from_rig] = *rig.NonRefSensors().begin();
  ASSERT_TRUE(sensor_from_rig.has_value());
  EXPECT_LT((Inverse(*sensor_from_rig).translation() -
             Eigen::Vector3d(options.rig_baseline, 0, 0))
                .norm(),
            1e-9);
  const Eigen::Vector3d viewing_direction =
      sensor_from_rig->rotation().inverse() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(RadToDeg(std::atan2(viewing_direction.x(),
                                  viewing_direction.z())),
              options.rig_yaw_deg,
              1e-9);
  EXPECT_NEAR(viewing_direction.y(), 0, 1e-12);
  const Rig& true_rig = truth.Rig(rig.RigId());
  EXPECT_EQ(true_rig.RefSensorId(), ref_sensor_id);
  EXPECT_LT((true_rig.SensorFromRig(sensor_id).ToMatrix() -
             sensor_from_rig->ToMatrix())
                .norm(),
            1e-12);

  // Frames of one image per camera, named by camera folder, the same name
  // after it; the true relative pose of the images is the rig's.
  ASSERT_EQ(database->NumFrames(), num_positions);
  for (const Frame& frame : database->ReadAllFrames()) {
    EXPECT_EQ(frame.RigId(), rig.RigId());
    ASSERT_EQ(frame.NumDataIds(), 2);
    EXPECT_TRUE(truth.Frame(frame.FrameId()).HasPose());
    std::map<sensor_t, const Image*> images;
    for (const data_t& data_id : frame.DataIds()) {
      const Image& image = truth.Image(static_cast<image_t>(data_id.id));
      EXPECT_EQ(image.FrameId(), frame.FrameId());
      EXPECT_EQ(image.DataId(), data_id);
      EXPECT_EQ(database->ReadImage(image.ImageId()).Name(), image.Name());
      images.emplace(data_id.sensor_id, &image);
    }
    ASSERT_EQ(images.size(), 2);
    const Image& ref_image = *images.at(ref_sensor_id);
    const Image& image = *images.at(sensor_id);
    ASSERT_EQ(ref_image.Name().substr(0, 5), "cam0/");
    ASSERT_EQ(image.Name().substr(0, 5), "cam1/");
    EXPECT_EQ(ref_image.Name().substr(5), image.Name().substr(5));
    const Rigid3d cam_from_ref =
        image.CamFromWorld() * Inverse(ref_image.CamFromWorld());
    EXPECT_LT((cam_from_ref.ToMatrix() - sensor_from_rig->ToMatrix()).norm(),
              1e-9);
    EXPECT_NEAR(
        (image.ProjectionCenter() - ref_image.ProjectionCenter()).norm(),
        options.rig_baseline,
        1e-9);
  }

  // The images of a snapshot see much the same: they are matched too.
  int num_verified_within_frames = 0;
  for (const auto& [pair_id, two_view_geometry] :
       database->ReadTwoViewGeometries()) {
    if (two_view_geometry.inlier_matches.empty()) {
      continue;
    }
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    num_verified_within_frames +=
        truth.Image(image_id1).FrameId() == truth.Image(image_id2).FrameId();
  }
  EXPECT_GT(num_verified_within_frames, num_positions / 2);

  // Keypoints are the true cameras' projections.
  Reconstruction reprojected = truth;
  reprojected.UpdatePoint3DErrors();
  EXPECT_LT(reprojected.ComputeMeanReprojectionError(), 1.0);
}

TEST(SyntheticSceneOptions, Check) {
  SyntheticSceneOptions options;
  EXPECT_TRUE(options.Check());
  options.num_clusters = 0;
  EXPECT_FALSE(options.Check());
  options = SyntheticSceneOptions();
  options.num_rig_cameras = 2;
  EXPECT_TRUE(options.Check());
  // A rig's cameras are one Camera each, shared by their images.
  options.single_camera = false;
  EXPECT_FALSE(options.Check());
  // The poster is repeated on two walls at least.
  options = SyntheticSceneOptions();
  options.num_repeated_texture_pairs = 1;
  EXPECT_TRUE(options.Check());
  options.num_clusters = 2;
  EXPECT_FALSE(options.Check());
}

}  // namespace
}  // namespace colmap
