#include "colmap_ext/merge/covisibility_check.h"

#include "colmap_ext/testing/synthetic_scene.h"

#include "colmap/math/math.h"
#include "colmap/util/types.h"

#include <map>
#include <optional>
#include <unordered_set>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// Two landmarks joined by a walkway; the "matcher" verified every pair that
// shares at least 15 points. Community 1 is landmark 0 with the first half
// of the walkway, community 2 the rest, each in a frame of its own.
class CheckCovisibilityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SyntheticSceneOptions options;
    options.num_clusters = 2;
    options.num_images_per_cluster = 20;
    options.num_images_per_link = 30;
    options.close_loop = false;
    options.num_points_per_cluster = 1500;
    options.num_points_per_link = 800;
    options.seed = 3;
    SynthesizeCommunityScene(options, &scene_, /*database=*/nullptr);
    const Reconstruction& truth = scene_.ground_truth;
    landmark_offset_ = Eigen::Vector3d(options.landmark_spacing, 0, 0);

    std::map<image_pair_t, int> num_shared;
    for (const auto& point3D : truth.Points3D()) {
      const auto& elements = point3D.second.track.Elements();
      for (size_t i = 0; i < elements.size(); ++i) {
        for (size_t j = 0; j < i; ++j) {
          ++num_shared[ImagePairToPairId(elements[i].image_id,
                                         elements[j].image_id)];
        }
      }
    }
    for (const auto& pair_and_count : num_shared) {
      if (pair_and_count.second >= 15) {
        verified_pairs_.insert(pair_and_count.first);
      }
    }

    // Walkway images go to the landmark they are nearer to.
    model1_ = truth;
    model2_ = truth;
    for (const image_t image_id : truth.RegImageIds()) {
      const Image& image = truth.Image(image_id);
      const int cluster = scene_.image_cluster.at(image_id);
      const bool first =
          cluster == 0 || (cluster < 0 && image.ProjectionCenter().x() < 0);
      (first ? model2_ : model1_).DeRegisterFrame(image.FrameId());
    }
    model1_.Transform(Inverse(world_from_model1_));
    model2_.Transform(Inverse(world_from_model2_));
  }

  bool IsVerified(const image_t image_id1, const image_t image_id2) const {
    return verified_pairs_.count(ImagePairToPairId(image_id1, image_id2)) > 0;
  }

  // `is_compared`: the pairs the matcher compared (all, if empty).
  CovisibilityCheck Check(
      const Sim3d& second_from_first,
      const std::function<bool(image_t, image_t)>& is_compared = {}) const {
    return CheckCovisibility(
        model1_,
        model2_,
        second_from_first,
        [this](image_t a, image_t b) { return IsVerified(a, b); },
        is_compared,
        CovisibilityCheckOptions());
  }

  // Whether the two images are in one model (then compared, as by a
  // matcher that compared each community's images among themselves).
  bool InOneModel(const image_t image_id1, const image_t image_id2) const {
    for (const Reconstruction* model : {&model1_, &model2_}) {
      if (model->Image(image_id1).HasPose() &&
          model->Image(image_id2).HasPose()) {
        return true;
      }
    }
    return false;
  }

  SyntheticScene scene_;
  Eigen::Vector3d landmark_offset_;
  std::unordered_set<image_pair_t> verified_pairs_;
  Reconstruction model1_;
  Reconstruction model2_;
  const Sim3d world_from_model1_ = Sim3d(
      2.0,
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())),
      Eigen::Vector3d(1, 2, 3));
  const Sim3d world_from_model2_ = Sim3d(
      0.5,
      Eigen::Quaterniond(Eigen::AngleAxisd(-1.0, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(-4, 0, 1));
};

TEST_F(CheckCovisibilityTest, TrueAlignmentExplainsTheMatches) {
  const CovisibilityCheck check =
      Check(Inverse(world_from_model2_) * world_from_model1_);
  EXPECT_TRUE(check.consistent);
  // The walkway's halves meet: there are co-visible pairs to judge by, and
  // the matcher verified them as often as those inside the models.
  EXPECT_GE(check.cross.num_predicted, 10);
  EXPECT_GT(check.internal.num_predicted, 100);
  EXPECT_GT(check.cross.Rate(), 0.5 * check.internal.Rate());
}

TEST_F(CheckCovisibilityTest, StackedLandmarksContradictTheMatches) {
  // The transform that puts the second landmark onto the first, as matches
  // between two identical towers would suggest.
  Sim3d stacked;
  stacked.translation() = landmark_offset_;
  const CovisibilityCheck check =
      Check(Inverse(world_from_model2_) * stacked * world_from_model1_);
  EXPECT_FALSE(check.consistent);
  EXPECT_GE(check.cross.num_predicted, 50);
  EXPECT_LT(check.cross.Rate(), 0.1 * check.internal.Rate());
}

TEST_F(CheckCovisibilityTest, PairsNeverComparedSayNothing) {
  // The matcher compared the images within each model and, across, only the
  // pairs it verified (as sequential matching compares the images near in
  // the sequence: the pairs it never compared are no evidence of a wrong
  // alignment).
  const auto compared = [this](image_t a, image_t b) {
    return InOneModel(a, b) || IsVerified(a, b);
  };
  Sim3d stacked;
  stacked.translation() = landmark_offset_;
  const CovisibilityCheck check = Check(
      Inverse(world_from_model2_) * stacked * world_from_model1_, compared);
  EXPECT_TRUE(check.consistent);
  EXPECT_EQ(check.cross.num_predicted, check.cross.num_verified);
  // The true alignment: as with every pair compared.
  const CovisibilityCheck truth =
      Check(Inverse(world_from_model2_) * world_from_model1_, compared);
  EXPECT_TRUE(truth.consistent);
  EXPECT_GT(truth.internal.num_predicted, 100);
  // Every pair compared across, the stacked alignment is still refused.
  const auto all_but_one = [](image_t a, image_t b) { return a != b; };
  EXPECT_FALSE(Check(Inverse(world_from_model2_) * stacked * world_from_model1_,
                     all_but_one)
                   .consistent);
}

TEST_F(CheckCovisibilityTest, ModelsFarApartSayNothing) {
  Sim3d far_apart;
  far_apart.translation() = Eigen::Vector3d(0, 1000, 0);
  const CovisibilityCheck check =
      Check(Inverse(world_from_model2_) * far_apart * world_from_model1_);
  EXPECT_TRUE(check.consistent);
  EXPECT_EQ(check.cross.num_predicted, 0);
}

// A wall seen by two groups of cameras whose rays to it are 46-58 degrees
// apart (as the two faces of a building's corner), each group a model of its
// own, rightly aligned. The matcher verified every pair within a group and
// none across: SIFT seldom matches across such a viewpoint change, so those
// pairs say nothing about the alignment (as at a corner of South
// Building's subset sb60_6, where a right link was refused at 60 degrees).
Reconstruction WallSeenFrom(const double tilt_deg,
                            const image_t first_image_id) {
  Reconstruction model;
  model.AddCameraWithTrivialRig(
      Camera::CreateFromModelName(1, "SIMPLE_PINHOLE", 2000, 2000, 2000));
  std::vector<Eigen::Vector3d> wall;
  for (double x = -4; x <= 4; x += 0.5) {
    for (double z = -12; z <= 12; z += 0.5) {
      wall.emplace_back(x, 0, z);
    }
  }
  constexpr double kDistance = 10;
  const double tilt = DegToRad(tilt_deg);
  std::vector<Track> tracks(wall.size());
  for (int k = 0; k < 5; ++k) {
    const double z = -8 + 4 * k;
    const Eigen::Vector3d center(
        kDistance * std::sin(tilt), kDistance * std::cos(tilt), z);
    Image image;
    image.SetImageId(first_image_id + k);
    image.SetCameraId(1);
    image.SetName(std::to_string(first_image_id + k));
    const Rigid3d cam_from_world = LookAt(center, Eigen::Vector3d(0, 0, z), 0);
    std::vector<Eigen::Vector2d> points2D;
    for (size_t i = 0; i < wall.size(); ++i) {
      const Eigen::Vector3d in_cam = cam_from_world * wall[i];
      if (in_cam.z() <= 0) {
        continue;
      }
      const std::optional<Eigen::Vector2d> xy =
          model.Camera(1).ImgFromCam(in_cam);
      if (xy && xy->x() >= 0 && xy->y() >= 0 && xy->x() < 2000 &&
          xy->y() < 2000) {
        tracks[i].AddElement(image.ImageId(), points2D.size());
        points2D.push_back(*xy);
      }
    }
    image.SetPoints2D(points2D);
    model.AddImageWithTrivialFrame(std::move(image), cam_from_world);
  }
  for (size_t i = 0; i < wall.size(); ++i) {
    if (tracks[i].Length() >= 2) {
      model.AddPoint3D(wall[i], tracks[i]);
    }
  }
  return model;
}

TEST(CheckCovisibility, PairsSeenUnderWideAnglesSayNothing) {
  const Reconstruction left = WallSeenFrom(-29, 1);
  const Reconstruction right = WallSeenFrom(29, 101);
  // Within a group, as the matcher verified.
  const auto is_verified = [](const image_t a, const image_t b) {
    return (a < 100) == (b < 100);
  };
  CovisibilityCheckOptions options;
  const CovisibilityCheck check = CheckCovisibility(
      left, right, Sim3d(), is_verified, /*is_compared_pair=*/{}, options);
  EXPECT_TRUE(check.consistent);
  EXPECT_LT(check.cross.num_predicted, options.min_num_predicted_pairs);
  EXPECT_GT(check.internal.num_predicted, 0);
  // Counting points under rays up to 60 degrees apart, the pairs across are
  // predicted co-visible, none was matched, and the right alignment is
  // refused.
  options.max_ray_angle_deg = 60;
  const CovisibilityCheck wide = CheckCovisibility(
      left, right, Sim3d(), is_verified, /*is_compared_pair=*/{}, options);
  EXPECT_GE(wide.cross.num_predicted, options.min_num_predicted_pairs);
  EXPECT_EQ(wide.cross.num_verified, 0);
  EXPECT_FALSE(wide.consistent);
}

// The same wall from two groups of cameras, 4 m apart in height within a
// group, the groups' rays to it 12 or 30 degrees apart, nothing matched
// across: both alignments are refused, the first on close views unmatched,
// the second on wide views alone (what a matcher at low resolution leaves
// unmatched).
TEST(CheckCovisibility, UnmatchedViewsRefuseTheAlignment) {
  const CovisibilityCheckOptions options;
  // The groups at -tilt and +tilt degrees, each pair within a group matched.
  const auto check_walls = [&options](const double tilt_deg) {
    return CheckCovisibility(
        WallSeenFrom(-tilt_deg, 1),
        WallSeenFrom(tilt_deg, 101),
        Sim3d(),
        [](const image_t a, const image_t b) { return (a < 100) == (b < 100); },
        /*is_compared_pair=*/{},
        options);
  };
  for (const double tilt_deg : {6.0, 15.0}) {
    const CovisibilityCheck check = check_walls(tilt_deg);
    EXPECT_FALSE(check.consistent) << tilt_deg;
    EXPECT_GE(check.cross.num_predicted, options.min_num_predicted_pairs)
        << tilt_deg;
    EXPECT_EQ(check.cross.num_verified, 0) << tilt_deg;
  }
}

TEST(CovisibilityCheckOptions, Check) {
  CovisibilityCheckOptions options;
  EXPECT_TRUE(options.Check());
  options.min_num_predicted_pairs = 0;
  EXPECT_FALSE(options.Check());
}

}  // namespace
}  // namespace colmap
