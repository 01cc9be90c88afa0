// Global similarity averaging of community reconstructions.
//
// CSfM (Cui et al., ICIP 2017), section 3. Community i is placed by
// world_from_community_i, X_world = s_i R_i X_i + T_i; an edge (i, j) carries
// the pairwise similarity X_j = s_ij R_ij X_i + t_ij (pairwise_similarity.h)
// and its inlier points. Three convex problems, the largest community of each
// part fixed, each weighted by the edge's confidence c_ij:
//   1. scale:        min sum_ij c_ij |log s_i - log s_j - log s_ij|
//                    (COLMAP's ADMM least absolute deviations solver);
//   2. rotation:     R_i = R_j R_ij by L1RA and IRLS (rotation_averaging.h);
//   3. translation:  min sum_ij c_ij |T_i - T_j - T_ij|_1 per coordinate,
//                    T_ij = median(s_j R_j X_j - s_i R_i X_i) over the edge's
//                    inlier points.
// Weighted L1 puts a cycle's disagreement on its least confident edge. An edge
// is judged by where the result puts its own inlier points (the median
// displacement of their two copies relative to their spread): the worst edge
// of each part beyond the bound leaves and the part is averaged again. Edges
// the images both communities registered contradict leave first, and a bridge
// (on no cycle) is kept only if those images confirm it. docs/design.md
// gives each rule's reason.

#pragma once

#include "colmap_ext/merge/pairwise_similarity.h"

#include "colmap/geometry/sim3.h"
#include "colmap/util/eigen_alignment.h"
#include "colmap/util/types.h"

#include <vector>

namespace colmap {

// An edge with fewer inliers than this counts with its weight (the image
// pairs that confirm it) times num_inliers / kFullSupportNumInliers, and a
// bridge with fewer needs two of its shared images placed alike: a hundred
// points fitted by one similarity do not fit by chance.
inline constexpr int kFullSupportNumInliers = 100;

// A community as the averaging sees it.
struct AveragedCommunity {
  // Registered images of its model: the largest community of each part is
  // the part's reference.
  int num_images = 0;
};

struct SimilarityAveragingOptions {
  // An edge on a cycle is rejected, the worst of each part first, when its
  // EdgeReport::relative_displacement after averaging exceeds this.
  double max_relative_displacement = 0.2;

  bool Check() const;
};

struct SimilarityAveragingResult {
  struct EdgeReport {
    // The median distance between the two placements of the edge's inlier
    // points in the world frame, relative to their spread: the residual an
    // edge is judged by (see max_relative_displacement).
    double relative_displacement = 0.0;
    // Whether the edge joins its communities in the result.
    bool kept = false;
    // Left out from the start: its shared images contradict it (at least
    // two, and no fewer than are placed alike, are placed elsewhere).
    bool contradicted = false;
    // Dropped as on no cycle of kept edges, with fewer than two shared
    // images placed alike (and fewer than kFullSupportNumInliers inliers).
    bool unconfirmed = false;
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

// Averages the relative similarities of communities 0..N-1. Every edge
// carries its inlier points.
SimilarityAveragingResult AverageSimilarities(
    const std::vector<AveragedCommunity>& communities,
    const std::vector<RelativeSimilarity>& relative_similarities,
    const SimilarityAveragingOptions& options);

}  // namespace colmap
