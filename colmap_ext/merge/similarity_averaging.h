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
// Every edge counts with a confidence: the images that observe its inlier
// points, in the community where they are fewer (at most the weaker
// community's registered images; a similarity is only as strong as the
// images it rests on), scaled down if the edge has few inliers, mapped to
// [0.6, 1] so that a majority of right edges around a community still
// outweighs a minority of wrong ones. On a cycle that does not close, weighted
// L1 averaging puts the whole disagreement on the least confident edge instead
// of spreading it over all (every spread has the same unweighted L1 cost), so
// the fault is found where it most likely is: in a small community, or a
// similarity resting on few images or few inliers. A community is judged by its
// edges alone, never by its own model's statistics: a community bent by drift
// fits its own observations as well as any.
//
// The images both communities registered (shared images) measure an edge's
// similarity directly: where at least two of them, and no fewer than are
// placed alike, are placed elsewhere by the two models under it, the
// similarity or one of its models is wrong where the two overlap, and the
// edge is left out before the averaging (with many inliers from misplaced
// images it could win over the right links of its cycle).
//
// Afterwards, an edge is judged by where the averaging puts its own inlier
// points: the two communities' copies of each point, both placed in the
// world frame, must lie within a fifth of their spread of each other (the
// median over the points). One bound on the points serves rotation, scale
// and translation at once, in the unit in which a similarity fitted to few
// or clustered points is still right where its points are. In each part, the
// edge furthest beyond the bound leaves and the part is averaged again
// (wrong edges pull the solution, so that right ones next to them can look
// wrong until they are out), until every edge on a cycle is within it. An
// edge on no cycle of kept edges (a bridge) is fitted as it is, right or
// wrong, so the bound cannot judge it, and the images both communities
// registered do: it is kept if at least two of them are placed alike (full
// support, many inliers, stands in for them). If the kept edges no longer
// connect all communities, every connected part gets its own frame, since a
// wrong merge is worse than two models. A link the averaging dropped can still
// be confirmed against the result (link_confirmation.h), and the global
// refinement over all images judges what the averaging kept.

#pragma once

#include "colmap_ext/merge/pairwise_similarity.h"
#include "colmap_ext/merge/rotation_averaging.h"

#include "colmap/geometry/sim3.h"
#include "colmap/util/eigen_alignment.h"
#include "colmap/util/types.h"

#include <vector>

namespace colmap {

// An edge with fewer inliers than this counts with its weight (the images it
// rests on) times num_inliers / kFullSupportNumInliers, and a bridge with
// fewer needs two of its shared images placed alike: a hundred points fitted
// by one similarity do not fit by chance.
inline constexpr int kFullSupportNumInliers = 100;

// A community as the averaging sees it.
struct AveragedCommunity {
  // Registered images of its model: the most its edges can weigh (see
  // RelativeSimilarity::num_supporting_images). The largest community of
  // each part is the part's reference.
  int num_images = 0;
};

struct SimilarityAveragingOptions {
  // Rotation averaging (L1RA + IRLS).
  RotationAveragingOptions rotation;

  // An edge on a cycle is rejected when, after averaging, the median
  // distance between the two placements of its inlier points exceeds this
  // fraction of their spread (EdgeReport::relative_displacement), the worst
  // of each part first.
  double max_relative_displacement = 0.2;

  bool Check() const;
};

struct SimilarityAveragingResult {
  struct EdgeReport {
    // The median distance between the two placements of the edge's inlier
    // points in the world frame, relative to their spread: the residual an
    // edge is judged by (see max_relative_displacement).
    double relative_displacement = 0.0;
    // How far the edge's own rotation and scale ratio are from the
    // averaging's (degrees, |log(s_i / (s_j s_ij))|), reported only.
    double rotation_residual_deg = 0.0;
    double log_scale_residual = 0.0;
    // Whether the edge joins its communities in the result.
    bool kept = false;
    // Left out from the start: the images both communities registered
    // contradict it (at least two, and no fewer than are placed alike, are
    // placed elsewhere by the two models under its similarity).
    bool contradicted = false;
    // Dropped because nothing confirms it: no cycle of kept edges passes
    // through it, and fewer than two of its shared images are placed alike
    // (without kFullSupportNumInliers inliers to stand in for them).
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

// The residuals of `edge` under the placement `world_from_community`
// (indexed by community), as the averaging judges its edges (see
// EdgeReport).
SimilarityAveragingResult::EdgeReport ComputeEdgeResiduals(
    const RelativeSimilarity& edge,
    const std::vector<Sim3d>& world_from_community);

// Whether the displacement of `report` is within `max_relative_displacement`
// (a non-finite one is not).
bool EdgeWithinBound(const SimilarityAveragingResult::EdgeReport& report,
                     double max_relative_displacement);

// Averages the relative similarities of communities 0..N-1. Every edge
// carries its inlier points.
SimilarityAveragingResult AverageSimilarities(
    const std::vector<AveragedCommunity>& communities,
    const std::vector<RelativeSimilarity>& relative_similarities,
    const SimilarityAveragingOptions& options);

}  // namespace colmap
