// Confirming, after the averaging, a link the co-visibility check rejected.
//
// A transform that the co-visibility check rejected
// (community_alignment.h) can still be confirmed by the merge. The check judges
// a link by the image pairs the matcher verified across it, and real
// photographs fail it where the matcher verified few of the pairs that see one
// structure from far apart along the way (the start and the end of a walk
// around a building). Where the two communities are joined through other kept
// links (a cycle), the averaging places them without that link. Measured
// against that placement as the averaging measures its kept links (the
// displacement of its inlier points, similarity_averaging.h), a right transform
// differs by the drift accumulated along the links that join them; two
// identical facades matched onto each other differ by the distance between them
// (several spreads), a flipped facade by 180 degrees, and communities joined by
// nothing else are in different parts. A confirmed transform's cross pairs are
// no false pairs: they close the loop in the refinement.
//
// Drift: each kept link places its communities about within the bound, and
// independent errors along a path of k links add up to about sqrt(k) times
// one link's (a random walk); over parallel paths, less. The displacement
// bound is therefore scaled by the square root of the effective resistance
// between the two communities in the graph of kept links (each link one
// unit: k on a path of k links, 1 over two parallel paths of 2; 1 where the
// kept links do not connect them), between 1 and `max_drift_factor`. The
// factor is capped low: a facade of repeated windows matched one period off
// lies a period from the right place, a third of a spread where the matches
// span ten periods.

#pragma once

#include "colmap_ext/merge/community_alignment.h"
#include "colmap_ext/merge/similarity_averaging.h"

#include <unordered_set>
#include <vector>

namespace colmap {

struct MergeResiduals {
  // Whether the averaging put both communities in one part; `report` and
  // `path_resistance` are only set then.
  bool joined = false;
  // The rejected transform's residuals under the averaged placement
  // (ComputeEdgeResiduals, similarity_averaging.h).
  SimilarityAveragingResult::EdgeReport report;
  // The effective resistance between the two communities in the graph of
  // the averaging's kept links, each link a unit resistance.
  double path_resistance = 0.0;

  // The factor the displacement bound is scaled by: sqrt(path_resistance)
  // clamped to [1, max_drift_factor].
  double DriftFactor(double max_drift_factor) const;
  bool WithinBound(double max_relative_displacement,
                   double max_drift_factor = 1.0) const;
};

// `similarities` are those the averaging was given (averaging.edges is
// indexed alike).
MergeResiduals ResidualsAgainstMerge(
    const RejectedSimilarity& rejected,
    const std::vector<RelativeSimilarity>& similarities,
    const SimilarityAveragingResult& averaging);

// The cross pairs of `community_similarities` that support only rejected
// transforms, but those of the transforms that the averaging's placement
// confirms (ResidualsAgainstMerge within `max_relative_displacement` scaled
// by at most `max_drift_factor`): they close a loop in the refinement. Logs
// each rejected transform's residuals and fate.
std::unordered_set<image_pair_t> ConfirmRejectedLinks(
    const CommunitySimilarities& community_similarities,
    const SimilarityAveragingResult& averaging,
    double max_relative_displacement,
    double max_drift_factor);

}  // namespace colmap
