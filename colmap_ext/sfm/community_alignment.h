// Pairwise similarities between the models of connected communities.
//
// CSfM (Cui et al., ICIP 2017), section 3: "given the co-visible 3D points
// between a pair of connected communities, RANSAC is used to estimate a 3D
// similarity transformation". Two communities are connected where the view
// graph has edges between their images (cross edges). Their co-visible
// points come from the verified matches of those edges and from the images
// both models registered (image_overlap): see pairwise_similarity.h.
//
// Every similarity is checked against the image pairs the matcher verified
// (covisibility_check.h); a rejected one gives way to the next estimated
// from its outliers, up to PairwiseSimilarityOptions::max_num_hypotheses.
// The cross pairs whose matches mostly supported rejected transforms (e.g.
// matches between two identical facades) are reported as false pairs: the
// merged model's refinement must not re-introduce them as tracks. The
// rejected transforms are reported too, each with its pairs, so that the
// merge can confirm one that a cycle of other links places alike
// (ResidualsAgainstMerge, below).

#pragma once

#include "colmap_ext/graph/view_graph.h"
#include "colmap_ext/sfm/covisibility_check.h"
#include "colmap_ext/sfm/pairwise_similarity.h"
#include "colmap_ext/sfm/similarity_averaging.h"

#include "colmap/scene/database.h"
#include "colmap/scene/reconstruction.h"

#include <map>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace colmap {

// View-graph edges between communities, by community pair (the smaller id
// first), each as the pair of its images in that order.
using CrossEdges =
    std::map<std::pair<int, int>, std::vector<std::pair<image_t, image_t>>>;

// Images without a community are left out.
CrossEdges GroupCrossEdges(
    const ViewGraph& view_graph,
    const std::unordered_map<image_t, int>& community_of_image);

// A transform that the co-visibility check rejected.
struct RejectedSimilarity {
  // The communities, the transform and its inliers (the shared images are
  // not checked for it).
  RelativeSimilarity similarity;
  // The cross pairs whose matches mostly support it.
  std::vector<image_pair_t> pairs;
  // The check that rejected it.
  CovisibilityCheck check;
};

struct CommunitySimilarities {
  // One per community pair with a usable similarity (with its inliers'
  // point ids).
  std::vector<RelativeSimilarity> similarities;
  // Cross pairs whose matches mostly support rejected transforms.
  std::unordered_set<image_pair_t> false_pairs;
  // The rejected transforms.
  std::vector<RejectedSimilarity> rejected_similarities;
};

// The similarities of every pair of communities that cross edges join and
// both of which have a model (models[c] may be null). The cross edges'
// matches are read from the database. The pairs are estimated on
// `num_threads` threads (-1: as many as the machine has), each with a random
// seed of its own: the result does not depend on the number of threads.
CommunitySimilarities EstimateCommunitySimilarities(
    const Database& database,
    const ViewGraph& view_graph,
    const CrossEdges& cross_edges,
    const std::vector<std::shared_ptr<const Reconstruction>>& models,
    const PairwiseSimilarityOptions& pairwise_options,
    const CovisibilityCheckOptions& covisibility_options,
    int num_threads = -1);

// A transform that the co-visibility check rejected but that the merge
// confirms. The check judges a link by the image pairs the matcher verified
// across it, and real photographs fail it where the matcher verified few of
// the pairs that see one structure from far apart along the way (the start
// and the end of a walk around a building, as on South Building:
// docs/design.md). Where the two communities are joined through other kept
// links (a cycle), the averaging places them without that link. Measured
// against that placement as the averaging measures its kept links (its
// residual bounds, similarity_averaging.h), a right transform differs by
// the drift accumulated along the links that join them; two identical
// facades matched onto each other differ by the distance between them
// (several spreads), a flipped facade by 180 degrees, and communities
// joined by nothing else are in different parts. A confirmed transform's
// cross pairs are no false pairs: they close the loop in the refinement.
//
// Drift: each kept link places its communities within the bounds, and
// independent errors along a path of k links add up to about sqrt(k) times
// one link's (a random walk); over parallel paths, less. The rotation and
// translation bounds are therefore scaled by the square root of the
// effective resistance between the two communities in the graph of kept
// links (each link one unit: k on a path of k links, 1 over two parallel
// paths of 2; 1 where the kept links do not connect them), between 1 and
// `max_drift_factor`; the scale bound (22%) is not. The factor is capped
// low: a facade of repeated windows matched one period off lies a period
// from the right place, a third of a spread where the matches span ten
// periods.
struct MergeResiduals {
  // Whether the averaging put both communities in one part (neither left
  // the merge); `report` and `path_resistance` are only set then.
  bool joined = false;
  // The rejected transform's residuals under the averaged placement
  // (ComputeEdgeResiduals, similarity_averaging.h).
  SimilarityAveragingResult::EdgeReport report;
  // The effective resistance between the two communities in the graph of
  // the averaging's kept links, each link a unit resistance.
  double path_resistance = 0.0;

  // The factor the rotation and translation bounds are scaled by:
  // sqrt(path_resistance) clamped to [1, max_drift_factor].
  double DriftFactor(double max_drift_factor) const;
  bool WithinBounds(const SimilarityAveragingOptions& bounds,
                    double max_drift_factor = 1.0) const;
};

// `similarities` are those the averaging was given (averaging.edges is
// indexed alike).
MergeResiduals ResidualsAgainstMerge(
    const RejectedSimilarity& rejected,
    const std::vector<RelativeSimilarity>& similarities,
    const SimilarityAveragingResult& averaging);

}  // namespace colmap
