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
// joined model is refined by bundle adjustment (merged_model_refiner.h).
//
// The merge judges its communities by their links alone, not by their own
// models' statistics (docs/design.md):
//   - a similarity that does not explain which images were matched is
//     rejected (covisibility_check.h); one the averaging places within its
//     bound all the same is confirmed, and its image pairs stay;
//   - links that disagree with the averaging are dropped; communities
//     joined by kept links form a part, merged into one model;
//   - the images of parts that no kept link joins to a larger one, and of
//     communities that left the merge, are offered to the larger part's
//     refinement, which registers them (a community's model as one block
//     where it fits); those nobody registers keep their community's model,
//     so no image is written in two models.
#pragma once

#include "colmap_ext/graph/view_graph.h"
#include "colmap_ext/scene/community_workspace.h"
#include "colmap_ext/sfm/community_alignment.h"
#include "colmap_ext/sfm/covisibility_check.h"
#include "colmap_ext/sfm/merged_model_refiner.h"
#include "colmap_ext/sfm/pairwise_similarity.h"
#include "colmap_ext/sfm/similarity_averaging.h"

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/reconstruction.h"

#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace colmap {

// What the incremental mapper of a community produced, for the run's
// summary (the merge judges a community by its links, not by these).
struct CommunityModelReport {
  // Registered images of the model that takes part in the merge (the
  // largest; 0 if there is none).
  int num_registered = 0;
  // Models the mapper made.
  int num_models = 0;
  // Which of the mapper's models takes part: 1 for the largest, 2 for the
  // second largest (an extra community), ...
  int model_index = 1;
};

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
  // lies within the averaging's displacement bound of that placement
  // (link_confirmation.h): its image pairs then
  // stay in the refinement and close the loop there. False: every rejected
  // similarity's pairs are left out.
  bool confirm_rejected_links = true;

  // That bound grows with the drift the links between the two communities
  // may have accumulated, as the square root of their effective resistance
  // (the number of links on a path), at most by this factor.
  double rejected_link_max_drift_factor = 1.5;

  // Global similarity averaging and the links it keeps.
  SimilarityAveragingOptions similarity_averaging;

  // Refinement of each merged model.
  MergedModelRefinementOptions refinement;

  // The incremental mapper's options for the registration, triangulation
  // and bundle adjustment of the merged models.
  IncrementalPipelineOptions incremental_options;

  bool Check() const;
};

// What the merge did and made.
struct CommunityMergeResult {
  // The merged models, largest first.
  std::vector<std::shared_ptr<Reconstruction>> models;
  // Per community of the merge (the plan's, then the extra communities:
  // other models of a community's mapper): what its mapper produced, and
  // whether it left the merge.
  std::vector<CommunityModelReport> community_reports;
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
  // Seconds of MergeParts() spent in the refinement of the merged models
  // (the rest joined the models, merged their points, loaded the
  // correspondences and the colours).
  double refinement_seconds = 0.0;
};

// The own images of every community: the plan's, then those of the extra
// communities that the merge adds.
struct CommunityImages {
  std::vector<std::unordered_set<image_t>> own_image_ids;
  std::unordered_map<image_t, std::string> name_of_image;
  std::unordered_map<image_t, int> community_of_image;
};

// The merge in three phases, which must run in this order (the controller
// times them apart):
//
//   CommunityMerge merge(options, plan, workspace);
//   merge.EstimateSimilarities();
//   merge.AverageSimilarities();
//   merge.MergeParts();
//   const CommunityMergeResult& result = merge.Result();
//
// Every community of the plan must have its record in `workspace`. A phase
// throws where the database or a model cannot be read.
class CommunityMerge {
 public:
  CommunityMerge(const CommunityMergeOptions& options,
                 const CommunityPlan& plan,
                 const CommunityWorkspace& workspace);

  // Reads the view graph and the communities' models as their stage wrote
  // them (with the extra communities), and estimates the similarity of
  // every two communities that view-graph edges join, checked against which
  // images were matched (community_alignment.h).
  void EstimateSimilarities();

  // Averages the similarities into one per community and keeps the links
  // that agree with it (similarity_averaging.h); confirms rejected links
  // the averaging places within the bound (link_confirmation.h).
  // Communities that left are set aside.
  void AverageSimilarities();

  // Joins the communities of every part into one model, merges their
  // corresponding points and refines it (MergedModelRefiner), largest part
  // first; the images of smaller parts and of communities that left are
  // offered to the larger part's refinement. Set-aside communities keep the
  // images no merged model registered as models of their own.
  void MergeParts();

  // What the merge did; its models once MergeParts() ran.
  const CommunityMergeResult& Result() const { return result_; }

 private:
  void ReadCommunityModels();
  void SetAsideExcludedCommunities();
  // Community c's model restricted to its own images that no model in
  // `taken_image_ids` registered: `model` (its copy in memory), or as its
  // stage wrote it if null.
  std::shared_ptr<Reconstruction> LeftModel(
      int c,
      std::shared_ptr<Reconstruction> model,
      const std::unordered_set<image_t>& taken_image_ids) const;
  // Adds a model to the result and its images to `registered_image_ids`.
  void KeepModel(std::shared_ptr<Reconstruction> model,
                 std::unordered_set<image_t>* registered_image_ids);
  // The communities of `part` with a model, and how many of their own
  // registered images no model in `registered_image_ids` holds.
  std::vector<int> PartCommunities(
      int part,
      const std::unordered_set<image_t>& registered_image_ids,
      size_t* num_left_images) const;
  // The set-aside communities' models of the images no model registered, of
  // at least Mapper.min_model_size images, kept as models of their own.
  void KeepSetAsideCommunities(
      std::unordered_set<image_t>* registered_image_ids);
  // MergePart's steps: the images without a pair left out of the part,
  // the joined points that correspond, the part's correspondences.
  void LeaveOutUnpairedImages(
      const std::unordered_set<std::string>& part_image_names,
      std::vector<std::unordered_set<image_t>>* owned_image_ids) const;
  std::vector<std::pair<point3D_t, point3D_t>> PartCorrespondingPoints(
      const std::vector<int>& part_communities,
      const std::map<int, size_t>& index_in_part,
      const std::vector<std::unordered_map<point3D_t, point3D_t>>& point3D_ids)
      const;
  std::shared_ptr<const DatabaseCache> LoadPartCorrespondences(
      const std::unordered_set<std::string>& part_image_names,
      const Reconstruction& merged) const;
  std::shared_ptr<Reconstruction> MergePart(
      const std::vector<int>& part_communities,
      const std::unordered_set<std::string>& extra_image_names,
      const std::unordered_set<image_t>& taken_image_ids,
      const std::vector<std::shared_ptr<const Reconstruction>>& offered_models);

  const CommunityMergeOptions options_;
  const CommunityPlan plan_;
  const CommunityWorkspace workspace_;

  // EstimateSimilarities(): the view graph, the communities' images, models
  // (null where a community has none or has been consumed) and their paths,
  // the view-graph edges between communities and the similarities.
  std::unique_ptr<ViewGraph> view_graph_;
  CommunityImages communities_;
  std::vector<std::shared_ptr<Reconstruction>> models_;
  std::vector<std::string> model_paths_;
  CrossEdges cross_edges_;
  CommunitySimilarities similarities_;

  // AverageSimilarities(): the placement and links kept, the image pairs
  // the refinement leaves out, and the communities that left the merge (set
  // aside), which may join as blocks.
  SimilarityAveragingResult averaging_;
  std::unordered_set<image_pair_t> false_pairs_;
  std::vector<int> set_aside_communities_;

  CommunityMergeResult result_;
  // How many of the three phases ran.
  int num_phases_done_ = 0;
};

// The three phases of CommunityMerge in one call.
CommunityMergeResult MergeCommunities(const CommunityMergeOptions& options,
                                      const CommunityPlan& plan,
                                      const CommunityWorkspace& workspace);

}  // namespace colmap
