// Relative similarity transform between two community reconstructions.
//
// CSfM (Cui et al., ICIP 2017), section 3: "given the co-visible 3D points
// between a pair of connected communities, RANSAC is used to estimate a 3D
// similarity transformation (Horn 1987), including relative scale-ratio,
// rotation and translation."
//
// Co-visible points come from the view graph's cross edges: a verified match
// between image i of community 1 and image j of community 2, whose keypoints
// observe 3D points X1 and X2 in their own reconstructions, makes the
// correspondence (X1, X2); each pair of 3D points counts once, however many
// matches link it. Where the communities share images (the controller's
// image_overlap), a shared image is passed as a "cross pair" of the image
// with itself, each keypoint matched to itself: a keypoint with a 3D point in
// both reconstructions is the most direct co-visibility there is. The
// transform X2 = s R X1 + t is estimated with COLMAP's
// SimilarityTransformEstimator inside LO-RANSAC. Reconstructions have
// arbitrary scale, so the inlier threshold is relative: a fraction of the
// spread (median distance to the median) of the correspondences in the
// second reconstruction.

#pragma once

#include "colmap/feature/types.h"
#include "colmap/geometry/sim3.h"
#include "colmap/scene/reconstruction.h"
#include "colmap/util/eigen_alignment.h"
#include "colmap/util/types.h"

#include <functional>
#include <vector>

namespace colmap {

// Per coordinate, the median of the points (at least one): of an even number
// the larger middle value, not their mean as colmap::Median.
Eigen::Vector3d CoordinateWiseMedian(
    const std::vector<Eigen::Vector3d>& points);

// Median distance of the points to their coordinate-wise median: a spread
// that a minority of outliers does not inflate (0 for no points).
double MedianDistanceToMedian(const std::vector<Eigen::Vector3d>& points);

// The verified matches of one view-graph edge between two communities.
struct CrossPairMatches {
  // Image of the first and of the second community.
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  // point2D_idx1 refers to image_id1, point2D_idx2 to image_id2.
  FeatureMatches matches;
};

struct PointCorrespondences {
  std::vector<point3D_t> point3D_ids1;
  std::vector<point3D_t> point3D_ids2;
  std::vector<Eigen::Vector3d> points1;
  std::vector<Eigen::Vector3d> points2;

  size_t Size() const { return points1.size(); }
};

// Collects the 3D-3D correspondences between the two reconstructions that
// the matches of the cross pairs reveal.
PointCorrespondences FindPointCorrespondences(
    const Reconstruction& reconstruction1,
    const Reconstruction& reconstruction2,
    const std::vector<CrossPairMatches>& cross_pairs);

struct PairwiseSimilarityOptions {
  // Inlier threshold as a fraction of the correspondences' spread.
  double max_relative_error = 0.05;

  // Minimum number of inlier correspondences for a usable transform. A
  // transform with few inliers still counts for less in the averaging
  // (kFullSupportNumInliers, similarity_averaging.h) and is judged by
  // where it puts its points, so a weak link closing a loop can be used.
  int min_num_inliers = 10;

  // Transforms tried when a check rejects one: each next one is estimated
  // from the correspondences that the rejected ones left as outliers (where
  // two communities are linked by true matches and by matches of repeated
  // structure, the latter can have the larger support).
  int max_num_hypotheses = 3;

  bool Check() const;
};

struct PairwiseSimilarity {
  bool success = false;
  // X2 = s R X1 + t.
  Sim3d second_from_first;
  int num_correspondences = 0;
  int num_inliers = 0;
  // The inlier correspondences (translation averaging re-uses them).
  std::vector<Eigen::Vector3d> inlier_points1;
  std::vector<Eigen::Vector3d> inlier_points2;
  std::vector<std::pair<point3D_t, point3D_t>> inlier_point3D_ids;
};

PairwiseSimilarity EstimatePairwiseSimilarity(
    const PointCorrespondences& correspondences,
    const PairwiseSimilarityOptions& options);

// The first of up to `options.max_num_hypotheses` transforms that `accept`
// accepts (see above); `num_rejected` receives how many it rejected. The
// result's `success` is false if none was accepted.
PairwiseSimilarity EstimatePairwiseSimilarity(
    const PointCorrespondences& correspondences,
    const PairwiseSimilarityOptions& options,
    const std::function<bool(const PairwiseSimilarity&)>& accept,
    int* num_rejected);

// The images that both reconstructions registered, checked against a
// transform X2 = s R X1 + t: a right transform between two right models
// maps every shared image's pose in the first onto its pose in the second.
// One that leaves some apart disagrees with one of the models (a model that
// registered an image of its neighbour in the wrong place, say): where
// nothing else checks the transform, that is reason not to trust it.
struct SharedImageAgreement {
  int num_shared_images = 0;
  int num_agreeing = 0;
  // Largest rotation (degrees) and relative distance over the shared images.
  double max_rotation_deg = 0.0;
  double max_relative_distance = 0.0;

  bool AllAgree() const { return num_agreeing == num_shared_images; }
};

// A shared image (registered by both reconstructions) agrees with a
// transform if the transform maps its pose in the first onto its pose in the
// second within 10 degrees and one `spread` (the correspondences' spread in
// the second, MedianDistanceToMedian): between how far right links place
// their shared images, an open chain's drifting ends included, and how far
// wrongly registered images are off.
SharedImageAgreement CheckSharedImages(const Reconstruction& reconstruction1,
                                       const Reconstruction& reconstruction2,
                                       const Sim3d& second_from_first,
                                       double spread);

// The fewer, over the two reconstructions, of the registered images that
// observe the points of `point3D_ids` (pairs of ids in the first and the
// second): how much of each model a similarity estimated from these points
// rests on. Points of a few images pin the two models together only
// through those images, however many images the models have.
int CountSupportingImages(
    const Reconstruction& reconstruction1,
    const Reconstruction& reconstruction2,
    const std::vector<std::pair<point3D_t, point3D_t>>& point3D_ids);

// A similarity between two communities' models, as the averaging takes it
// (similarity_averaging.h).
struct RelativeSimilarity {
  int community1 = -1;
  int community2 = -1;
  // X2 = s R X1 + t.
  Sim3d second_from_first;
  // Inlier correspondences (X1, X2), at least one: the averaging takes the
  // translation from them and judges the similarity by where it puts them.
  // Their 3D point ids in the two models (for the merge; the averaging does
  // not use them).
  std::vector<Eigen::Vector3d> points1;
  std::vector<Eigen::Vector3d> points2;
  std::vector<std::pair<point3D_t, point3D_t>> point3D_ids;
  // Support (number of inlier correspondences).
  double num_inliers = 0;
  // The images that observe its inlier points, in the model where they are
  // fewer (CountSupportingImages; 0: not known, the communities' sizes
  // stand in).
  int num_supporting_images = 0;
  // Images both models registered, and how many of them the similarity
  // maps onto their other copy (pairwise_similarity.h, CheckSharedImages).
  int num_shared_images = 0;
  int num_agreeing_shared_images = 0;
};

}  // namespace colmap
