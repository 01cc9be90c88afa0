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
// images it rests on), scaled down if the edge has few inliers or its
// shared images are in doubt (below), mapped to [0.6, 1] so that a
// majority of right edges around a community still outweighs a minority of
// wrong ones. On a cycle that does not close, weighted L1 averaging puts
// the whole disagreement on the least confident edge instead of spreading
// it over all (every spread has the same unweighted L1 cost), so the fault
// is found where it most likely is: in a small community, or a similarity
// resting on few images or few inliers. A community is judged by its edges
// alone, never by its own model's statistics: a community bent by drift fits
// its own observations as well as any.
//
// Afterwards, an edge is judged by where the averaging puts its own inlier
// points: the two communities' copies of each point, both placed in the
// world frame, must lie within a fifth of their spread of each other (the
// median over the points). One bound on the points serves rotation, scale
// and translation at once, in the unit in which a similarity fitted to few
// or clustered points is still right where its points are: its rotation
// alone can be degrees off (a weak link closing a loop, say) while its
// points still sit well within the displacement bound. Edges beyond the
// bound are reported and left out, the one furthest beyond it in each part
// first, and the averaging is repeated (wrong edges pull the solution, so
// that right ones next to them can look wrong until they are out). A
// part's only edge beyond the bound (with `reject_worst_first`; a bridge,
// which the bridge rule below judges, does not count) stays, its
// displacement as averaged with it in, where the part's other edges,
// averaged without it, place its points within the bound: averaged with it
// in, the rotations lean toward its rotation (degrees off where it was
// fitted to a few clustered points), and a small patch of points far from
// a community's origin moves with that lean by more than its spread
// allows; the other edges alone say where its points belong. Before that, a
// disagreement that is drift rather than a fault is told apart: if
// every edge beyond the bound is confirmed by the images its two
// communities both registered, the part is averaged again in least squares
// (every edge alike, translations in units of their spreads), which spreads
// a long loop's gap over all its edges; if that brings every edge within
// the bound, that solution stands (`spread_cycle_drift`). The weaker
// community of a rejected edge leaves the merge altogether if it is small
// and fewer than two kept edges confirm it (its images and its model can
// still join the merged model later): a community that drifts or broke
// inside itself cannot be aligned to all its neighbours by one similarity,
// and keeping it by its last edge would bend the merged model. An edge that
// lies on no cycle of kept edges (a bridge) is fitted as it is, right or
// wrong, and not judged by the bound: it is kept only if the images both
// communities registered confirm it, at least two of them placed alike by
// the two models under its similarity and at most one not; full support (many
// inliers) stands in for the images placed alike, and fewer placed elsewhere
// than alike do not veto it. Right links place all their shared images alike
// but for single borrowed images placed wrongly by one model, while a wrong
// bridge places many of its shared images elsewhere, or has none. If the
// kept edges no longer connect all communities, every connected part gets
// its own frame, since a wrong merge is worse than two models.
//
// Before any averaging, an edge that its shared images contradict (at
// least two of them placed elsewhere, and no fewer than placed alike) is
// left out: at least one of its two models misplaced those images, or the
// similarity is wrong, and on a cycle such an edge can pull the averaging
// its way (with many inliers from the misplaced images it can win over the
// right links of its cycle and cut the merge into parts). Fewer
// placed elsewhere than alike, but at least two, put the edge in doubt: it
// stays in the averaging with a tenth of its weight, so that a cycle
// through it that does not close drops it rather than a right edge of a
// small community.

#pragma once

#include "colmap_ext/merge/pairwise_similarity.h"
#include "colmap_ext/merge/rotation_averaging.h"

#include "colmap/geometry/sim3.h"
#include "colmap/util/eigen_alignment.h"
#include "colmap/util/types.h"

#include <vector>

namespace colmap {

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

  // Solve the scale and translation problems in least squares instead of
  // L1 (for comparison only: not robust to wrong edges).
  bool least_squares = false;

  // An edge on a cycle is rejected when, after averaging, the median
  // distance between the two placements of its inlier points exceeds this
  // fraction of their spread (EdgeReport::relative_displacement), unless it
  // is its part's only such edge and the other edges place its points
  // within it (see above).
  double max_relative_displacement = 0.2;

  // Rounds of rejection and re-averaging (0: keep every edge).
  int max_num_rejection_rounds = 5;

  // Each round rejects only the edge of each part that is beyond the bound
  // by the largest factor (wrong edges distort the averaging, so that right
  // ones next to them can look wrong until they are out); there are then as
  // many rounds as edges, at most (but 0 still keeps every edge). False:
  // every edge beyond the bound goes at once.
  bool reject_worst_first = true;

  // Drift on a long cycle: where the L1 averaging of a part leaves edges
  // beyond the bound above, but each of them is confirmed by the images
  // both of its communities registered (at least
  // `min_num_confirming_shared_images`, every one placed alike under its
  // similarity, and the farthest apart no further than the bound above, in
  // the same unit), the part's scales and translations are averaged again in
  // least squares (every edge alike, translations in units of their
  // correspondences' spread; rotations stay robustly averaged), which
  // spreads a cycle's disagreement over all its edges as loop closure
  // spreads drift; if every edge of the part is then within the bound,
  // that solution is kept and nothing is rejected. A similarity that is
  // wrong by more than the bound moves the copies of its shared images
  // apart by as much, and a bent one keeps its points apart; drift
  // accumulated around a loop of many communities leaves every link locally
  // right. Where some edges beyond the bound are confirmed and others not,
  // the others are rejected first and the confirmed ones judged again in the
  // next round, without them. Without it, a long loop's gap falls on the
  // edges of its smallest community, which leaves the merge, and the loop
  // stays open.
  bool spread_cycle_drift = true;
  int min_num_confirming_shared_images = 2;

  // The weight of an edge in doubt (see min_num_contradicting_shared_images)
  // as a fraction of its weight.
  double doubtful_weight = 0.1;

  // An edge with fewer inliers than this counts with its weight (the images
  // it rests on) times num_inliers / full_support_num_inliers (and a bridge
  // needs its shared images to confirm it, see below).
  double full_support_num_inliers = 100;

  // The weaker community of a rejected edge leaves the merge if it has fewer
  // registered images than this fraction of the median community's (and
  // fewer than two kept edges).
  double min_relative_size = 0.5;

  // An edge is in doubt when at least this many of the images both
  // communities registered are placed elsewhere by the two models under its
  // similarity (0: never): it counts with `doubtful_weight` in the
  // averaging, so that a cycle through it that does not close puts its
  // disagreement there. Where also no fewer are placed alike, it is left out
  // of the averaging from the start.
  int min_num_contradicting_shared_images = 2;

  // An edge that lies on no cycle of kept edges (a bridge) is dropped unless
  // at least this many of the images both communities registered are placed
  // alike by the two models under its similarity and at most one is not
  // (`full_support_num_inliers` inliers stand in for the former, and fewer
  // placed elsewhere than alike are then allowed).
  int min_num_shared_images_on_bridge = 2;

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
    // Dropped because nothing confirms it: no cycle of kept edges passes
    // through it, and its shared images disagree or are too few.
    bool unconfirmed = false;
    // Left out from the start: its shared images contradict it (see
    // min_num_contradicting_shared_images).
    bool contradicted = false;
    // Dropped with one of its communities, which left the merge (see
    // min_relative_size).
    bool community_left = false;
  };

  // Part (connected by kept edges) of each community, 0..NumParts()-1,
  // parts ordered by their total size, largest first.
  std::vector<int> part_of_community;
  // The community's transform into its part's frame; the largest community
  // of each part is its reference (identity).
  std::vector<Sim3d> world_from_community;
  std::vector<EdgeReport> edges;
  // Communities that left the merge (each is a part of its own).
  std::vector<bool> excluded;

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
