// Generated scenes with community structure and known ground truth.
//
// The scene models what community-based SfM is made for: several landmarks,
// each photographed densely by a cluster of cameras around it, joined by
// sparser chains of cameras along walkways, optionally closing a loop. All
// geometry is on a ground plane (z up, metres):
//   - landmark c is a textured tower (a cylinder of points) on a square of
//     textured ground, the cluster's cameras stand on a ring around it and
//     look at it; towers occlude what lies behind them;
//   - walkway c joins landmark c to landmark c+1; it is lined on its left
//     by a textured wall from tower to tower, and its cameras walk along it
//     10 m from the wall, looking at the wall, turning over the first and
//     last quarter of the walk towards the tower behind or ahead. The
//     number of walkway cameras sets the chain's density: consecutive
//     cameras overlap more the more there are.
// A point is observed by a camera when it lies in front of it within
// `max_viewing_distance`, projects into the image, faces the camera (tower
// and ground points have normals; walkway features do not) and is not hidden
// by a tower.
//
// The database holds what COLMAP's feature extractor, matcher and
// geometric verification write: one camera (or one per image), each the only
// sensor of a rig of its own, images, each in a frame of its own, or, with a
// multi-camera rig, what `colmap rig_configurator` makes of them: one rig of
// one camera per rig sensor with its true sensor_from_rig, and per camera
// position one frame (one snapshot of the rig) of one image per camera;
// keypoints (observations with Gaussian noise, plus distractor keypoints
// without a 3D point, shuffled); raw matches, as a matcher leaves them: the
// true correspondences of every pair sharing at least
// `min_num_shared_points` points plus a share of wrong matches (random, or
// near the pair's epipolar line as repeated texture makes them), pairs of
// unrelated images matched by chance, and pairs of unrelated images matched
// on repeated structure (identical towers, the same poster on two walls),
// whose matches one rigid motion or one homography explains. The two-view
// geometries are then estimated from the raw matches by COLMAP's own
// geometric verification with its default options (VerifyMatchedPairs), as
// `colmap geometric_verifier` does: they hold the inliers RANSAC keeps and no
// relative pose, never the truth. Images are written in a random order. The
// same options and seed give the same bytes.

#pragma once

#include "colmap/scene/database.h"
#include "colmap/scene/reconstruction.h"

#include <string>
#include <vector>

namespace colmap {

struct SyntheticSceneOptions {
  // Number of landmarks, each with its own cluster of cameras.
  int num_clusters = 3;

  // Number of cameras around each landmark.
  int num_images_per_cluster = 40;

  // Number of cameras on each walkway between consecutive landmarks (the
  // density of the chains; 0 leaves the clusters unconnected).
  int num_images_per_link = 12;

  // Whether a walkway also joins the last landmark to the first one.
  bool close_loop = true;

  // Distance between neighbouring landmarks (metres).
  double landmark_spacing = 70.0;

  // Number of 3D points on each landmark (tower and ground).
  int num_points_per_cluster = 3000;

  // Number of 3D points along each walkway.
  int num_points_per_link = 1200;

  // Image size (pixels) and focal length (pixels) of the SIMPLE_RADIAL
  // camera(s); the radial distortion is zero.
  int image_width = 1024;
  int image_height = 768;
  double focal_length = 900.0;

  // One camera shared by all images (as `--ImageReader.single_camera 1`) or
  // one camera per image.
  bool single_camera = true;

  // Number of cameras of a rig that takes every picture (2: a stereo rig).
  // Every camera position then becomes a frame, one snapshot of the rig,
  // holding one image per camera; the position is the reference camera's
  // (camera 0). Every camera of the rig is a Camera of its own (the same
  // nominal intrinsics; needs `single_camera`), its images named
  // "cam<k>/image<i>.jpg" (one folder per camera, as rig_configurator's
  // image prefixes). 1: no rig, every image in a frame of its own.
  int num_rig_cameras = 1;

  // Camera k of the rig stands k * `rig_baseline` (metres) to the right of
  // the reference camera, turned right by k * `rig_yaw_deg` about its
  // vertical axis (0: parallel stereo, the usual rig; a few degrees: the
  // cameras diverge to widen the rig's field of view).
  double rig_baseline = 0.3;
  double rig_yaw_deg = 0.0;

  // Relative standard deviation of every camera's true focal length around
  // `focal_length`, the value the database holds (as a focal length read
  // from EXIF, off by a few percent); 0: the database holds the true one.
  double focal_length_noise = 0.0;

  // Standard deviation of the keypoint noise (pixels).
  double keypoint_noise = 0.5;

  // Keypoints without a 3D point, per image.
  int num_distractor_keypoints = 100;

  // Points further away than this are not observed (metres).
  double max_viewing_distance = 40.0;

  // A pair of images is matched if it shares at least this many points.
  int min_num_shared_points = 15;

  // Fraction of every matched pair's raw matches that are wrong, as a
  // matcher's ratio test lets them through.
  double wrong_match_fraction = 0.25;

  // Share of those wrong matches that lie within 4 pixels of their epipolar
  // line (COLMAP's default verification threshold), as repeated texture
  // along the line makes them: verification keeps them among the inliers.
  // The others pair random keypoints, most of which verification rejects.
  double epipolar_wrong_match_share = 0.25;

  // Number of pairs of images that share no point matched by chance, each
  // on `false_pair_num_matches` random keypoints (verification rejects
  // them, as a real matcher's).
  int num_false_pairs = 0;
  int false_pair_num_matches = 30;

  // Number of pairs falsely matched on repeated structure: all towers are
  // then copies of the first (the same points around their own centre) and
  // such a pair, between images of two different landmarks that see at
  // least `min_num_shared_points` corresponding tower points, matches those
  // points' keypoints. Their matches agree with one rigid motion (the one
  // that stacks one tower on the other), as those between two identical
  // buildings do, and pass verification.
  int num_repeated_structure_pairs = 0;

  // Number of pairs falsely matched on repeated planar texture: every wall
  // then carries the same poster (in place of its own texture there, at a
  // random place of its middle half) and such a pair, between
  // walkway images of two different walls that see at least
  // `min_num_shared_points` corresponding poster points, matches those
  // points' keypoints. One homography explains their matches, as those
  // between two identical facades or window patterns.
  int num_repeated_texture_pairs = 0;

  // For unit tests that need exact geometry instead of a verification: every
  // matched pair is written as verified, all its raw matches its inliers,
  // with its true relative pose (the stacked copy's for repeated structure).
  bool exact_two_view_geometries = false;

  // Threads of the verification (-1: all).
  int num_threads = -1;

  // Seed of the random number generator.
  unsigned int seed = 0;

  bool Check() const;
};

struct SyntheticScene {
  // The ground truth: cameras and their rigs, registered frames, images
  // with their keypoints (points2D; those observing a point carry its id)
  // and 3D points. Rig, frame, camera and image ids are the database's.
  Reconstruction ground_truth;

  // For every image: the landmark cluster it belongs to (0..num_clusters-1)
  // or -1 for walkway images.
  std::unordered_map<image_t, int> image_cluster;

  // Pairs with raw matches: sharing points, matched by chance, matched on
  // repeated structure or texture.
  int num_matched_pairs = 0;
  int num_false_pairs = 0;
  int num_repeated_structure_pairs = 0;
  int num_repeated_texture_pairs = 0;
  // The verification's outcome: pairs with a two-view geometry of at least
  // its minimum number of inliers, and the raw and inlier matches of all.
  int num_verified_pairs = 0;
  size_t num_raw_matches = 0;
  size_t num_inlier_matches = 0;
};

// Generates the scene and, if `database` is given, writes it to the
// (empty) database.
void SynthesizeCommunityScene(const SyntheticSceneOptions& options,
                              SyntheticScene* scene,
                              Database* database);

// A start for an adjustment to undo: every registered frame of
// `reconstruction` (with one image per frame: every registered image) turned
// by up to `max_rotation_deg` about a random axis and moved by up to
// `translation_fraction` of the extent of the camera centres along each axis,
// every point moved as far, every camera's first parameter (a focal length)
// scaled by `focal_length_factor`. The same seed gives the same moves
// (COLMAP's random generator, seeded).
void PerturbReconstruction(double max_rotation_deg,
                           double translation_fraction,
                           double focal_length_factor,
                           unsigned seed,
                           Reconstruction* reconstruction);

// The pose of a camera at `center` looking towards `target`, its image rows
// horizontal (world z up), rolled by `roll` (radians) about its axis.
Rigid3d LookAt(const Eigen::Vector3d& center,
               const Eigen::Vector3d& target,
               double roll);

// Writes "IMAGE_NAME CLUSTER" lines (cluster -1: walkway) to a text file.
void WriteImageClusters(const SyntheticScene& scene, const std::string& path);

}  // namespace colmap
