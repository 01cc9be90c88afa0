// The merge stage of Community-based SfM: the community models of a plan,
// as their stage wrote them, into one model per part in one frame.
//
// Cui, Shen, Gao and Hu, "CSfM: Community-based Structure from Motion",
// ICIP 2017, sections 3.3-3.4, in four stages after COLMAP 4.1.1's
// GlobalMapper::Solve: 1. pairwise similarities (community_alignment.h),
// 2. similarity averaging into parts (similarity_averaging.h), 3. global
// refinement of each part and 4. registration of the images no community
// placed (global_refinement.h). A part that no link joins stays a model of
// its own; no image is in two models. docs/design.md, Merge stages 1-4,
// gives the rules' reasons.
#pragma once

#include "colmap_ext/merge/community_alignment.h"
#include "colmap_ext/merge/covisibility_check.h"
#include "colmap_ext/merge/pairwise_similarity.h"
#include "colmap_ext/merge/similarity_averaging.h"
#include "colmap_ext/partition/view_graph.h"
#include "colmap_ext/workflow/community_workspace.h"

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/database_cache.h"
#include "colmap/scene/reconstruction.h"

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

struct CommunityMergerOptions {
  // The database the communities were reconstructed from (view graph,
  // matches and correspondences).
  std::string database_path;

  // The image folder (only for the points' colours).
  std::string image_path;

  // Only these images (empty: every image of the database), as the plan's.
  std::unordered_set<std::string> image_names;

  // Minimum verified inlier matches of a view-graph edge.
  int min_num_matches = 15;

  PairwiseSimilarityOptions pairwise_similarity;

  CovisibilityCheckOptions covisibility_check;

  SimilarityAveragingOptions similarity_averaging;

  // The user's --Mapper.*: the refinement's intrinsics and threads, and the
  // registration of the remaining images.
  IncrementalPipelineOptions incremental_options;

  // Relative function tolerance at which the merged model's adjustments
  // (stage 3) stop; the registration's follow incremental_options.
  double refinement_function_tolerance = 1e-6;

  // Stage 3 off: each part's joined model goes to the registration as the
  // averaging placed it.
  bool skip_global_refinement = false;
  // Stage 4 off: the images no community registered stay unregistered, and
  // the parts no link joins stay models of their own.
  bool skip_registration = false;

  bool Check() const;
};

// What the merge did and made.
struct CommunityMergerResult {
  // The merged models, largest first.
  std::vector<std::shared_ptr<Reconstruction>> models;
  // Per community of the merge (the plan's, then the extra communities:
  // other models of a community's mapper): what its mapper produced.
  std::vector<CommunityModelReport> community_reports;
  // The plan's community each extra community comes from.
  std::vector<int> extra_community_origins;
  // The plan's community of every image of the view graph.
  std::unordered_map<image_t, int> community_of_image;
  // View graph of the merge (a resumed run's summary counts it).
  int num_view_graph_images = 0;
  int num_view_graph_edges = 0;
  // Pairs of communities joined by view-graph edges, with a similarity,
  // and kept by the averaging.
  int num_community_pairs = 0;
  int num_estimated_similarities = 0;
  int num_kept_similarities = 0;
  // The seconds of every stage, by name, in order.
  std::vector<std::pair<std::string, double>> stage_seconds;
};

// The own images of every community: the plan's, then those of the extra
// communities that the merge adds.
struct CommunityImages {
  std::vector<std::unordered_set<image_t>> own_image_ids;
  std::unordered_map<image_t, std::string> name_of_image;
  std::unordered_map<image_t, int> community_of_image;
};

// The merge, in its stages (see the top of this file):
//
//   CommunityMerger merger(options, plan, workspace);
//   merger.Solve();
//   const CommunityMergerResult& result = merger.Result();
//
// Every community of the plan must have its record in `workspace`. Solve()
// throws where the database or a model cannot be read.
class CommunityMerger {
 public:
  CommunityMerger(const CommunityMergerOptions& options,
                  const CommunityPlan& plan,
                  const CommunityWorkspace& workspace);

  // Runs the stages once.
  void Solve();

  // What the merge did and made, once Solve() ran.
  const CommunityMergerResult& Result() const { return result_; }

 private:
  // A part's model between the stages.
  struct PartModel {
    std::shared_ptr<Reconstruction> model;
    // The part's communities, and those whose images are offered to it.
    std::vector<int> communities;
    std::vector<int> offered_communities;
    // Whether the model joins several communities.
    bool joined = false;
  };

  // Stage 1 (with the communities' models read) and stage 2.
  void EstimateSimilarities();
  void ReadCommunityModels();
  void AddExtraCommunities(const CommunityRecord& record);
  void AverageSimilarities();
  // Stage 3: every part's model.
  void JoinAndRefineParts();
  std::shared_ptr<Reconstruction> JoinPart(
      const std::vector<int>& part_communities);
  void RefinePart(const std::shared_ptr<Reconstruction>& merged) const;
  // Stage 4: the remaining images registered into the parts' models, which
  // are kept.
  void RegisterRemainingImagesOfParts();
  bool RegisterIntoPart(const std::unordered_set<std::string>& image_names,
                        std::shared_ptr<Reconstruction>* model) const;

  // Community c's model restricted to its own images: `model` (its copy in
  // memory), or as its stage wrote it if null.
  std::shared_ptr<Reconstruction> OwnModel(
      int c, std::shared_ptr<Reconstruction> model) const;
  // The correspondences of `model`'s registered images and `image_names`,
  // without the false pairs; every registered image must have some.
  std::shared_ptr<DatabaseCache> LoadPartCorrespondences(
      const std::unordered_set<std::string>& image_names,
      const Reconstruction& model) const;

  const CommunityMergerOptions options_;
  const CommunityPlan plan_;
  const CommunityWorkspace workspace_;
  bool solved_ = false;

  // Stage 1: the view graph, the communities' images, models (null where
  // none or consumed) and paths, and the cross edges.
  std::unique_ptr<ViewGraph> view_graph_;
  CommunityImages communities_;
  std::vector<std::shared_ptr<Reconstruction>> models_;
  std::vector<std::string> model_paths_;
  CrossEdges cross_edges_;
  // The similarities, and the image pairs stages 3 and 4 leave out.
  CommunitySimilarities similarities_;

  // Stage 2: the placement and links kept.
  SimilarityAveragingResult averaging_;

  // Stage 3: the parts' models, largest part first.
  std::vector<PartModel> part_models_;

  CommunityMergerResult result_;
};

}  // namespace colmap
