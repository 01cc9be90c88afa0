// The merge stage of Community-based SfM: the community models of a plan,
// as their stage wrote them, into one model per part in one frame.
//
// Cui, Shen, Gao and Hu, "CSfM: Community-based Structure from Motion",
// ICIP 2017, sections 3.3-3.4. Every pair of communities that view-graph
// edges connect gets a similarity from their co-visible points
// (community_alignment.h); the similarities are averaged into one
// similarity per community, world_from_community (similarity_averaging.h:
// L1 scale, L1RA rotation and L1 translation averaging), the communities
// are transformed and joined, their corresponding points merged, and the
// joined model is refined by bundle adjustment (community_merger.h).
//
// The merge judges what it merges (docs/design.md):
//   - a community whose model is broken leaves the merge, one in doubt
//     counts little in the averaging (community_judgement.h);
//   - a similarity that does not explain which images were matched is
//     rejected (covisibility_check.h); one the averaging places within its
//     bounds all the same is confirmed, and its image pairs stay;
//   - links that disagree with the averaging are dropped; communities
//     joined by kept links form a part, merged into one model;
//   - the images of parts that no kept link joins to a larger one, and of
//     communities that left the merge, are offered to the larger part's
//     refinement, which registers them (a community's model as one block
//     where it can); those nobody registers keep their community's model,
//     so no image is written in two models.
#pragma once

#include "colmap_ext/scene/community_workspace.h"
#include "colmap_ext/sfm/community_judgement.h"
#include "colmap_ext/sfm/community_merger.h"
#include "colmap_ext/sfm/covisibility_check.h"
#include "colmap_ext/sfm/pairwise_similarity.h"
#include "colmap_ext/sfm/similarity_averaging.h"

#include "colmap/controllers/incremental_mapper.h"
#include "colmap/scene/reconstruction.h"

#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace colmap {

struct CommunityMergeOptions {
  // The database the communities were reconstructed from (view graph,
  // matches and correspondences).
  std::string database_path;

  // The image folder (only for the points' colours).
  std::string image_path;

  // Only these images (empty: every image of the database), as the plan's.
  std::unordered_set<std::string> image_names;

  // Minimum verified inlier matches of a view-graph edge.
  int min_num_matches = 15;

  // Where a community's mapper made several models, each other model that
  // holds at least incremental_options.min_model_size of the community's
  // own images (that no larger model of it holds) takes part in the merge
  // as an extra community; false: only the largest does, and the
  // refinement registers the others' images one by one.
  bool merge_other_models = true;

  // Pairwise similarity estimation between connected communities.
  PairwiseSimilarityOptions pairwise_similarity;

  // The check that an alignment explains which images were matched.
  CovisibilityCheckOptions covisibility_check;

  // A similarity the co-visibility check rejected, between two communities
  // that the averaging joins through other links, is confirmed where it
  // lies within the averaging's residual bounds of that placement
  // (link_confirmation.h): its image pairs then
  // stay in the refinement and close the loop there. False: every rejected
  // similarity's pairs are left out.
  bool confirm_rejected_links = true;

  // Those bounds grow with the drift the links between the two communities
  // may have accumulated, as the square root of their effective resistance
  // (the number of links on a path), at most by this factor.
  double rejected_link_max_drift_factor = 1.5;

  // What makes a community's own model doubtful or broken.
  CommunityJudgementOptions judgement;

  // Global similarity averaging and the links it keeps.
  SimilarityAveragingOptions similarity_averaging;

  // Refinement of each merged model.
  MergedModelRefinementOptions refinement;

  // The incremental mapper's options for the registration, triangulation
  // and bundle adjustment of the merged models.
  IncrementalMapperOptions incremental_options;

  bool Check() const;
};

// What the merge did and made.
struct CommunityMergeResult {
  // The merged models, largest first.
  std::vector<std::shared_ptr<Reconstruction>> models;
  // Per community of the merge (the plan's, then the extra communities:
  // other models of a community's mapper): what its mapper produced, the
  // verdict on its model, and whether it left the merge.
  std::vector<CommunityModelReport> community_reports;
  std::vector<CommunityJudgement> community_judgements;
  std::vector<bool> community_excluded;
  // The plan's community each extra community comes from.
  std::vector<int> extra_community_origins;
  // The plan's community of every image of the view graph.
  std::unordered_map<image_t, int> community_of_image;
  // View graph of the merge.
  int num_view_graph_images = 0;
  int num_view_graph_edges = 0;
  // Pairs of communities joined by view-graph edges, with a similarity,
  // and kept by the averaging.
  int num_community_pairs = 0;
  int num_estimated_similarities = 0;
  int num_kept_similarities = 0;
  // Seconds: the similarities and their averaging; joining the models
  // (with the correspondences' loading and colours); their refinement.
  double averaging_seconds = 0.0;
  double merge_seconds = 0.0;
  double refinement_seconds = 0.0;
};

// Merges the communities of `plan`, whose models and records are in
// `workspace` (every community of the plan must have its record). Throws
// where the database or a model cannot be read.
CommunityMergeResult MergeCommunities(const CommunityMergeOptions& options,
                                      const CommunityPlan& plan,
                                      const CommunityWorkspace& workspace);

}  // namespace colmap
