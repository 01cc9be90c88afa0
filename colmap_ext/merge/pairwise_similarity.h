// Relative similarity transform between two community reconstructions.
//
// CSfM (Cui et al., ICIP 2017), section 3: from the co-visible 3D points of
// two connected communities, RANSAC estimates X2 = s R X1 + t (Horn 1987;
// COLMAP's SimilarityTransformEstimator in LO-RANSAC), its inliers within a
// fraction of the correspondences' spread (median distance to the median) in
// the second reconstruction. A verified match across the two whose keypoints
// observe X1 and X2 makes the correspondence (X1, X2), each pair of points
// once; a shared image is passed as a cross pair of the image with itself,
// each keypoint matched to itself. docs/design.md, Merge stage 1, gives the
// rules' reasons.

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

// Whether `reconstruction` holds `image_id` with a pose (registered).
inline bool HasPosedImage(const Reconstruction& reconstruction,
                          const image_t image_id) {
  return reconstruction.ExistsImage(image_id) &&
         reconstruction.Image(image_id).HasPose();
}

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

  // Minimum number of inlier correspondences for a usable transform (fewer
  // than kFullSupportNumInliers count for less, similarity_averaging.h).
  int min_num_inliers = 10;

  // Transforms tried in all when a check rejects one: each next one from the
  // correspondences that the rejected ones left as outliers.
  int max_num_hypotheses = 3;

  bool Check() const;
};

struct PairwiseSimilarity {
  bool success = false;
  // X2 = s R X1 + t.
  Sim3d second_from_first;
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
// transform X2 = s R X1 + t: a right transform between two right models maps
// every shared image's pose in the first onto its pose in the second.
struct SharedImageAgreement {
  int num_shared_images = 0;
  int num_agreeing = 0;
  // Largest rotation (degrees) and relative distance over the shared images.
  double max_rotation_deg = 0.0;
  double max_relative_distance = 0.0;
};

// A shared image agrees with the transform if it maps its pose in the first
// onto its pose in the second within 10 degrees and one `spread` (the
// correspondences' spread in the second, MedianDistanceToMedian).
SharedImageAgreement CheckSharedImages(const Reconstruction& reconstruction1,
                                       const Reconstruction& reconstruction2,
                                       const Sim3d& second_from_first,
                                       double spread);

// How many of `cross_pairs` (images of the first and of the second
// reconstruction) `second_from_first` explains: the two cameras as it places
// them put most of the pair's matches within COLMAP's two-view verification
// error (TwoViewGeometryOptions) of their epipolar lines.
int CountExplainedCrossPairs(const Reconstruction& reconstruction1,
                             const Reconstruction& reconstruction2,
                             const Sim3d& second_from_first,
                             const std::vector<CrossPairMatches>& cross_pairs);

// A similarity between two communities' models, as the averaging takes it
// (similarity_averaging.h).
struct RelativeSimilarity {
  int community1 = -1;
  int community2 = -1;
  // X2 = s R X1 + t.
  Sim3d second_from_first;
  // Inlier correspondences (X1, X2), at least one.
  std::vector<Eigen::Vector3d> points1;
  std::vector<Eigen::Vector3d> points2;
  // Support (number of inlier correspondences).
  double num_inliers = 0;
  // The verified pairs between the two communities' own images whose
  // matches it explains (CountExplainedCrossPairs).
  int num_explained_cross_pairs = 0;
  // Images both models registered, and how many of them the similarity
  // maps onto their other copy (pairwise_similarity.h, CheckSharedImages).
  int num_shared_images = 0;
  int num_agreeing_shared_images = 0;
};

}  // namespace colmap
