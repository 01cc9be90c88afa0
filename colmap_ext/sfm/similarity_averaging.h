// Global similarity averaging of community reconstructions.
//
// CSfM (Cui et al., ICIP 2017), section 3. Community i's reconstruction is
// mapped into the global frame by world_from_community_i:
//     X_world = s_i R_i X_i + T_i.
// An edge (i, j) carries the pairwise similarity X_j = s_ij R_ij X_i + t_ij
// (pairwise_similarity.h) and its inlier correspondences (X_i, X_j). The
// unknowns are found by three convex problems, each with the reference
// community (the largest) fixed:
//   1. scale (3.1):        min sum_ij |log s_i - log s_j - log s_ij|,
//      solved by COLMAP's ADMM least absolute deviations solver;
//   2. rotation (3.2):     R_i = R_j R_ij, by L1RA and IRLS
//      (rotation_averaging.h, on R_i^T);
//   3. translation (3.3):  with scales and rotations applied, each edge's
//      translation is re-estimated from its correspondences,
//      T_ij = median(s_j R_j X_j - s_i R_i X_i), then
//      min sum_ij |T_i - T_j - T_ij|_1  (per coordinate).
// Afterwards, edges whose residuals stay large (rotation, scale ratio, or
// translation relative to the spread of the edge's correspondences) are
// reported and left out, and the averaging is repeated; if the kept edges no
// longer connect all communities, every connected part gets its own frame,
// since a wrong merge is worse than two models.

#pragma once

#include "colmap_ext/sfm/rotation_averaging.h"

#include "colmap/geometry/sim3.h"
#include "colmap/util/eigen_alignment.h"

#include <vector>

namespace colmap {

struct RelativeSimilarity {
  int community1 = -1;
  int community2 = -1;
  // X2 = s R X1 + t.
  Sim3d second_from_first;
  // Inlier correspondences (X1, X2); if empty, t of second_from_first is
  // used for the translation.
  std::vector<Eigen::Vector3d> points1;
  std::vector<Eigen::Vector3d> points2;
  // Confidence (e.g. number of inliers), for the rotation spanning tree.
  double weight = 1.0;
};

struct SimilarityAveragingOptions {
  // Rotation averaging (L1RA + IRLS).
  RotationAveragingOptions rotation;

  // Solve the scale and translation problems in least squares instead of
  // L1 (for comparison only: not robust to wrong edges).
  bool least_squares = false;

  // An edge is rejected when, after averaging, its rotation residual (deg),
  // its scale ratio residual |log(s_i / (s_j s_ij))| or its translation
  // residual relative to the spread of its correspondences exceeds these.
  double max_rotation_residual_deg = 5.0;
  double max_log_scale_residual = 0.2;
  double max_relative_translation_residual = 0.2;

  // Rounds of rejection and re-averaging (0: keep every edge).
  int max_num_rejection_rounds = 5;

  bool Check() const;
};

struct SimilarityAveragingResult {
  struct EdgeReport {
    double rotation_residual_deg = 0.0;
    double log_scale_residual = 0.0;
    double relative_translation_residual = 0.0;
    // Whether the edge joins its communities in the result.
    bool kept = false;
  };

  // Part (connected by kept edges) of each community, 0..NumParts()-1,
  // parts ordered by their total size, largest first.
  std::vector<int> part_of_community;
  // The community's transform into its part's frame; the largest community
  // of each part is its reference (identity).
  std::vector<Sim3d> world_from_community;
  std::vector<EdgeReport> edges;

  int NumParts() const;
};

// Averages the relative similarities of communities 0..num_communities-1,
// community_sizes giving the size of each (the largest of a part is its
// reference).
SimilarityAveragingResult AverageSimilarities(
    const std::vector<int>& community_sizes,
    const std::vector<RelativeSimilarity>& relative_similarities,
    const SimilarityAveragingOptions& options);

}  // namespace colmap
