// Pairwise similarities between the models of connected communities.
//
// CSfM (Cui et al., ICIP 2017), section 3: "given the co-visible 3D points
// between a pair of connected communities, RANSAC is used to estimate a 3D
// similarity transformation". Communities are connected by view-graph edges
// between their images (cross edges); their co-visible points come from
// those edges' matches and the images both models registered (image_overlap;
// pairwise_similarity.h). A similarity the co-visibility check rejects
// (covisibility_check.h) gives way to the next from its outliers. Cross pairs
// whose matches mostly supported rejected transforms (two identical facades)
// are false pairs, which the merged model's tracks must leave out.

#pragma once

#include "colmap_ext/partition/view_graph.h"
#include "colmap_ext/merge/covisibility_check.h"
#include "colmap_ext/merge/pairwise_similarity.h"

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

struct CommunitySimilarities {
  // One per community pair with a usable similarity.
  std::vector<RelativeSimilarity> similarities;
  // Cross pairs whose matches mostly support rejected transforms.
  std::unordered_set<image_pair_t> false_pairs;
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

}  // namespace colmap
