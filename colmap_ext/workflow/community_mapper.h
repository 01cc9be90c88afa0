// Community-based Structure from Motion (CSfM).
//
// Cui, Shen, Gao and Hu, "CSfM: Community-based Structure from Motion",
// ICIP 2017. The view graph of the database is split into communities of
// images with dense connections inside and sparse ones outside (greedy
// modularity, recursive, small communities merged); every community is
// reconstructed on its own, in parallel, by COLMAP's incremental mapper; the
// community models are brought into one frame by global similarity
// averaging (L1 scale, L1RA rotation and L1 translation averaging of the
// pairwise similarities between connected communities), joined and refined
// over all images (community_merger.h).
//
// Compared with COLMAP's HierarchicalPipeline, which partitions by
// METIS into overlapping clusters and merges them pair by pair, the
// partition follows the view graph's own structure, the merge is global and
// judges what it merges, and the merged model is bundle adjusted.
//
// Where the merge cannot join communities (no similarity found, or one it
// does not trust), it still gives what the incremental mapper would: the
// images of a part that no similarity joins to a larger one are offered to
// the larger part's model, whose incremental mapper registers those it can;
// no image is written in two models.
//
// The work is done in three stages over files in the output folder
// (community_workspace.h), each a method that another process, or a
// cluster's job, can run alone: Partition(), ReconstructCommunity(K) for
// every community, Merge(). Run() does all three in one process and resumes
// an earlier run of the same plan: the communities that have a record are
// not reconstructed again.

#pragma once

#include "colmap_ext/partition/community_detection.h"
#include "colmap_ext/partition/view_graph.h"
#include "colmap_ext/workflow/community_workspace.h"
#include "colmap_ext/workflow/community_mapper_summary.h"
#include "colmap_ext/merge/community_merger.h"

#include "colmap/controllers/incremental_pipeline.h"
#include "colmap/scene/reconstruction_manager.h"
#include "colmap/util/base_controller.h"

#include <memory>
#include <mutex>
#include <string>
#include <unordered_set>
#include <vector>

namespace colmap {

class CommunityMapperController : public BaseController {
 public:
  struct Options {
    // The path to the image folder (only used for the points' colours).
    std::string image_path;

    // The path to the database file which is used as input.
    std::string database_path;

    // Only these images are reconstructed (empty: every image of the
    // database), as colmap mapper's --Mapper.image_list_path: the view graph
    // holds the pairs of two of them. The command records the list in
    // plan_options.
    std::unordered_set<std::string> image_names;

    // The output folder (community_workspace.h): the plan, communities.txt,
    // communities/K/ (one model per community, written as soon as it is
    // done, and its record), communities.ply. Required.
    std::string output_path;

    // The options that shape the partition and the communities, as
    // "key=value" lines (the command fills them in). The plan records them;
    // the later stages refuse a plan made with others.
    std::string plan_options;

    // Community detection: the modularity threshold (CSfM: 0.3), the
    // minimum community size (CSfM: N = 20), the balance rule.
    CommunityDetectionOptions community_detection;

    // Edge weights for community detection: every edge 1, as in the paper,
    // or its verified inlier count.
    ViewGraphEdgeWeight edge_weight = ViewGraphEdgeWeight::kUnit;

    // Number of images each community borrows from each neighbouring
    // community, so that neighbours share images and points for the
    // pairwise similarities (0: communities share nothing, as in the paper,
    // and only the matches of cross edges link them).
    int image_overlap = 3;

    // Number of communities reconstructed at the same time; -1: as many as
    // there are CPU cores (at most the number of communities). The threads
    // are split evenly among the workers.
    int num_workers = -1;

    // Relative function tolerance at which the global bundle adjustments of
    // the communities' mappers and the merged model's refinement stop; -1
    // takes incremental_options.ba_global_function_tolerance (COLMAP's 0
    // runs every global adjustment to its iteration limit). The plan's only
    // community, whose model is the result, runs the mapper's own.
    double ba_function_tolerance = 1e-6;

    // The merge stage (community_merger.h). Its database_path, image_path,
    // image_names, min_num_matches, incremental_options and
    // refinement_function_tolerance are this struct's (MergeOptions()).
    CommunityMergerOptions merge;

    // Options of the incremental mapper (per community, and for the
    // registration, triangulation and bundle adjustment of the merge). Its
    // min_num_matches is the view graph's too.
    IncrementalPipelineOptions incremental_options;

    // The merge stage's options, with this struct's inputs in effect.
    CommunityMergerOptions MergeOptions() const;

    // The incremental mapper's options for one community's images:
    // incremental_options with the community's images (sorted) and
    // image_path, num_threads threads if incremental_options leaves it to
    // the machine, and ba_function_tolerance unless it is the
    // plan's `only_community`.
    IncrementalPipelineOptions CommunityIncrementalOptions(
        const std::unordered_set<std::string>& image_names,
        int num_threads,
        bool only_community = false) const;

    bool Check() const;
  };

  // What happened (community_mapper_summary.h).
  using Summary = CommunityMapperSummary;
  static std::string SummaryToText(const Summary& summary) {
    return CommunityMapperSummaryToText(summary);
  }

  CommunityMapperController(
      const Options& options,
      std::shared_ptr<ReconstructionManager> reconstruction_manager);

  // Stage 1: the view graph, its communities, communities.txt and the plan.
  // False (with the reason logged) if the database has no view graph.
  bool Partition();

  // Stage 2: reconstructs one community of the plan into communities/K/ and
  // writes its record. False if there is no plan that fits this run's
  // database and options, or K is not in it.
  bool ReconstructCommunity(int community_id);

  // Stage 3 (CommunityMerger::Solve: pairwise similarities, their
  // averaging, global refinement, registration): merges the communities of
  // the plan from their models and records on disk into
  // reconstruction_manager (largest first) and writes communities.ply. Where
  // a community's mapper made several models, the others that hold enough
  // of its images take part as extra communities.
  // False if the plan does not fit, or communities have no record yet (they
  // are named).
  bool Merge();

  // All three stages; where the output folder holds a plan that fits, the
  // partition is read from it and communities with a record are reused.
  // False if a stage failed (logged).
  bool RunAllStages();

  // RunAllStages(), as a BaseController.
  void Run() override;

  const Summary& GetSummary() const { return summary_; }

 private:
  // Reads the plan and checks that it fits this run; logs why not.
  bool LoadPlan();
  // The plan's figures (the partition's and the communities' sizes) in the
  // summary.
  void SummarizePlan();
  // Reconstructs the community with `num_threads` threads and writes its
  // model and record.
  bool ReconstructAndRecord(int community_id,
                            int num_threads,
                            std::mutex* database_mutex);
  // Whether the community has a record that fits the plan.
  bool IsReconstructed(int community_id) const;
  // Whether every community of the plan has its record; logs those that
  // have not otherwise.
  bool CheckAllReconstructed() const;
  // Records a phase's time in the summary and logs it with the memory.
  void EndPhase(const std::string& name, double seconds);

  const Options options_;
  const CommunityWorkspace workspace_;
  std::shared_ptr<ReconstructionManager> reconstruction_manager_;
  std::string database_fingerprint_;
  CommunityPlan plan_;
  bool has_plan_ = false;
  Summary summary_;
};

}  // namespace colmap
