#include "colmap_ext/sfm/pose_graph_alignment.h"

#include "colmap/geometry/pose.h"
#include "colmap/geometry/sim3.h"

#include <cmath>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// A walk of `num_images` cameras along x, one unit apart, looking at a wall
// (z = 4) along their way; every wall point is seen by the cameras within
// 3 units of it, and the points of a distant landmark (z = 60), if asked,
// by all. Image i has id i + 1 and camera 1.
Reconstruction Walk(int num_images, bool landmark = false) {
  Reconstruction reconstruction;
  Camera camera = Camera::CreateFromModelName(1, "PINHOLE", 500, 640, 480);
  reconstruction.AddCamera(camera);
  std::vector<Eigen::Vector3d> points;
  for (double x = -2; x <= num_images + 2; x += 0.25) {
    for (double y = -1.5; y <= 1.5; y += 0.5) {
      points.emplace_back(x, y, 4.0 + 0.3 * std::sin(3 * x + y));
    }
  }
  const size_t num_wall_points = points.size();
  for (int k = 0; landmark && k < 60; ++k) {
    points.emplace_back(
        0.5 * num_images + 8 * std::sin(k), 4 * std::cos(2 * k), 60 + k % 7);
  }
  std::vector<std::vector<std::pair<point2D_t, size_t>>> observations(
      points.size());
  for (int i = 0; i < num_images; ++i) {
    Image image;
    image.SetImageId(i + 1);
    image.SetCameraId(1);
    image.SetName("image" + std::to_string(i));
    // Looking along +z with a small yaw that varies along the walk.
    image.CamFromWorld().rotation = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.05 * std::sin(i), Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d center(i, 0.1 * std::cos(i), 0);
    image.CamFromWorld().translation =
        -(image.CamFromWorld().rotation * center);
    std::vector<Eigen::Vector2d> points2D;
    for (size_t p = 0; p < points.size(); ++p) {
      if (p >= num_wall_points || std::abs(points[p].x() - i) <= 3.0) {
        const Eigen::Vector3d in_cam = image.CamFromWorld() * points[p];
        observations[p].emplace_back(points2D.size(), i + 1);
        points2D.push_back(camera.ImgFromCam(in_cam.hnormalized()));
      }
    }
    image.SetPoints2D(points2D);
    reconstruction.AddImage(std::move(image));
    reconstruction.RegisterImage(i + 1);
  }
  for (size_t p = 0; p < points.size(); ++p) {
    Track track;
    for (const auto& observation : observations[p]) {
      track.AddElement(observation.second, observation.first);
    }
    if (track.Length() >= 2) {
      reconstruction.AddPoint3D(points[p], std::move(track));
    }
  }
  return reconstruction;
}

// The reconstruction without the images outside [first, last] (ids).
Reconstruction Piece(const Reconstruction& walk, image_t first, image_t last) {
  Reconstruction piece = walk;
  for (const image_t image_id : walk.RegImageIds()) {
    if (image_id < first || image_id > last) {
      piece.DeRegisterImage(image_id);
    }
  }
  return piece;
}

double MaxCenterError(const Reconstruction& reconstruction,
                      const Reconstruction& truth) {
  double max_error = 0;
  for (const image_t image_id : reconstruction.RegImageIds()) {
    max_error = std::max(max_error,
                         (reconstruction.Image(image_id).ProjectionCenter() -
                          truth.Image(image_id).ProjectionCenter())
                             .norm());
  }
  return max_error;
}

// Moves the images in [first, last] and the points first seen by them with
// `transform` (as a wrong similarity would place a community).
void MoveImages(const Sim3d& transform,
                image_t first,
                image_t last,
                Reconstruction* reconstruction) {
  for (const image_t image_id : reconstruction->RegImageIds()) {
    if (image_id < first || image_id > last) {
      continue;
    }
    Image& image = reconstruction->Image(image_id);
    const Sim3d cam_from_world(
        1, image.CamFromWorld().rotation, image.CamFromWorld().translation);
    const Sim3d moved = cam_from_world * Inverse(transform);
    image.CamFromWorld() =
        Rigid3d(moved.rotation, moved.translation / moved.scale);
  }
  for (const point3D_t point3D_id : reconstruction->Point3DIds()) {
    Point3D& point3D = reconstruction->Point3D(point3D_id);
    const image_t image_id = point3D.track.Element(0).image_id;
    if (image_id >= first && image_id <= last) {
      point3D.xyz = transform * point3D.xyz;
    }
  }
}

TEST(PoseGraphAlignment, CovisibilityEdgesAreTheModelsRelativePoses) {
  const Reconstruction walk = Walk(10);
  PoseGraphAlignmentOptions options;
  options.max_num_neighbors = 2;
  const std::vector<PoseGraphEdge> edges = CovisibilityEdges(walk, options);
  ASSERT_FALSE(edges.empty());
  for (const PoseGraphEdge& edge : edges) {
    // Only near neighbours share enough points (each sees 3 units).
    EXPECT_LE(std::abs(static_cast<int>(edge.image_id1) -
                       static_cast<int>(edge.image_id2)),
              2);
    const Rigid3d expected = walk.Image(edge.image_id1).CamFromWorld() *
                             Inverse(walk.Image(edge.image_id2).CamFromWorld());
    EXPECT_LT((edge.cam1_from_cam2.translation - expected.translation).norm(),
              1e-9);
    EXPECT_NEAR(edge.length_scale, 1.0, 0.05);
  }
  // Every image has an edge.
  std::set<image_t> linked;
  for (const PoseGraphEdge& edge : edges) {
    linked.insert(edge.image_id1);
    linked.insert(edge.image_id2);
  }
  EXPECT_EQ(linked.size(), 10);
}

std::unordered_set<image_t> Range(image_t first, image_t last) {
  std::unordered_set<image_t> image_ids;
  for (image_t image_id = first; image_id <= last; ++image_id) {
    image_ids.insert(image_id);
  }
  return image_ids;
}

TEST(PoseGraphAlignment, ConsistentCommunitiesKeepTheirPoses) {
  const Reconstruction walk = Walk(20);
  const Reconstruction community1 = Piece(walk, 1, 12);
  const Reconstruction community2 = Piece(walk, 10, 20);
  Reconstruction joined = walk;
  const PoseGraphAlignmentSummary summary =
      AlignPoseGraph({&community1, &community2},
                     {Range(1, 12), Range(13, 20)},
                     PoseGraphAlignmentOptions(),
                     &joined);
  EXPECT_EQ(summary.num_images, 23);  // 10-12 are in both.
  EXPECT_LT(summary.initial_cost, 1e-12);
  EXPECT_LT(MaxCenterError(joined, walk), 1e-9);
}

// The second community registered one of the images it borrowed far from
// where the first has it (as on a repeated structure): that image is not
// tied, and nothing moves.
TEST(PoseGraphAlignment, DoesNotTieAnImagePlacedFarOff) {
  const Reconstruction walk = Walk(20);
  const Reconstruction community1 = Piece(walk, 1, 12);
  Reconstruction community2 = Piece(walk, 10, 20);
  const Eigen::Vector3d center = walk.Image(11).ProjectionCenter();
  MoveImages(Sim3d(1,
                   Eigen::Quaterniond(
                       Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY())),
                   Eigen::Vector3d(0, 0, 6)) *
                 Sim3d(1, Eigen::Quaterniond::Identity(), -center),
             11,
             11,
             &community2);
  Reconstruction joined = walk;
  const PoseGraphAlignmentSummary summary =
      AlignPoseGraph({&community1, &community2},
                     {Range(1, 12), Range(13, 20)},
                     PoseGraphAlignmentOptions(),
                     &joined);
  EXPECT_EQ(summary.num_ties, 2);
  EXPECT_EQ(summary.num_dropped_ties, 1);
  EXPECT_LT(MaxCenterError(joined, walk), 1e-3);
}

// The second community was placed by a wrong similarity (3 degrees, scale
// 1.2, shifted): the images it shares with the first tie it back.
TEST(PoseGraphAlignment, PullsAMisplacedCommunityBack) {
  const Reconstruction walk = Walk(20);
  const Reconstruction community1 = Piece(walk, 1, 12);
  Reconstruction community2 = Piece(walk, 10, 20);
  const Sim3d wrong(
      1.2,
      Eigen::Quaterniond(Eigen::AngleAxisd(
          3 * M_PI / 180, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
      Eigen::Vector3d(0.3, -0.2, 0.5));
  MoveImages(wrong, 10, 20, &community2);
  // The joined model: images 1-12 (and their points) from the first
  // community, 13-20 from the second.
  Reconstruction joined = walk;
  MoveImages(wrong, 13, 20, &joined);
  ASSERT_GT(MaxCenterError(joined, walk), 0.5);

  const PoseGraphAlignmentSummary summary =
      AlignPoseGraph({&community1, &community2},
                     {Range(1, 12), Range(13, 20)},
                     PoseGraphAlignmentOptions(),
                     &joined);
  EXPECT_GT(summary.initial_cost, 1e-3);
  EXPECT_LT(summary.final_cost, 1e-10);
  EXPECT_LT(MaxCenterError(joined, walk), 1e-4);
  // The points moved with their cameras: they reproject again.
  joined.UpdatePoint3DErrors();
  EXPECT_LT(joined.ComputeMeanReprojectionError(), 1e-3);
}

// A community bent inside itself (each step turns by 1 degree and shrinks
// by 2% more than the truth), placed by one similarity that fits its first
// end, between the two ends of one sound community (as on a loop): its far
// end is off. The graph spreads the disagreement over its edges.
TEST(PoseGraphAlignment, SpreadsTheBendOfACommunityAcrossALoop) {
  // The landmark ties the sound community's two ends together.
  const Reconstruction walk = Walk(30, /*landmark=*/true);
  Reconstruction sound = walk;
  for (image_t image_id = 13; image_id <= 18; ++image_id) {
    sound.DeRegisterImage(image_id);
  }
  Reconstruction bent = Piece(walk, 10, 21);
  const Eigen::Vector3d origin = walk.Image(10).ProjectionCenter();
  for (image_t image_id = 11; image_id <= 21; ++image_id) {
    const double k = image_id - 10;
    const Sim3d drift(std::pow(0.98, k),
                      Eigen::Quaterniond(Eigen::AngleAxisd(
                          k * M_PI / 180, Eigen::Vector3d::UnitY())),
                      Eigen::Vector3d::Zero());
    MoveImages(Sim3d(1, Eigen::Quaterniond::Identity(), origin) * drift *
                   Sim3d(1, Eigen::Quaterniond::Identity(), -origin),
               image_id,
               image_id,
               &bent);
  }
  Reconstruction joined = walk;
  for (image_t image_id = 13; image_id <= 18; ++image_id) {
    joined.Image(image_id).CamFromWorld() = bent.Image(image_id).CamFromWorld();
  }
  std::unordered_set<image_t> sound_images = Range(1, 30);
  for (image_t image_id = 13; image_id <= 18; ++image_id) {
    sound_images.erase(image_id);
  }
  const double error_before = MaxCenterError(joined, walk);
  ASSERT_GT(error_before, 0.1);

  const PoseGraphAlignmentSummary summary =
      AlignPoseGraph({&sound, &bent},
                     {sound_images, Range(13, 18)},
                     PoseGraphAlignmentOptions(),
                     &joined);
  EXPECT_GT(summary.num_edges, 30);
  // Measured: 1.58 -> 0.53.
  EXPECT_LT(MaxCenterError(joined, walk), 0.5 * error_before);
}

}  // namespace
}  // namespace colmap
