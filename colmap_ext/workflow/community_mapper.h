// Community-based Structure from Motion (CSfM): the controller.
//
// Cui, Shen, Gao and Hu, "CSfM: Community-based Structure from Motion",
// ICIP 2017: the view graph is split into communities
// (community_detection.h), each reconstructed alone, in parallel, by COLMAP's
// incremental mapper, and the community models are placed in one frame by
// global similarity averaging, joined and refined (community_merger.h). Three
// stages over the output folder (community_workspace.h), each a method
// another process can run alone: Partition(), ReconstructCommunity(K),
// Merge(); Run() does all three and resumes an earlier run of the same plan.
// docs/design.md gives the rules' reasons.

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

    // Only these images (empty: every image of the database), as colmap
    // mapper's --Mapper.image_list_path; the command records them in the plan.
    std::unordered_set<std::string> image_names;

    // The output folder (community_workspace.h). Required.
    std::string output_path;

    // "key=value" lines of the options that shape the plan (the command
    // fills them in); the later stages refuse a plan made with others.
    std::string plan_options;

    CommunityDetectionOptions community_detection;

    // Edge weights for community detection: 1 (the paper) or inlier count.
    ViewGraphEdgeWeight edge_weight = ViewGraphEdgeWeight::kUnit;

    // Images each community borrows from each neighbouring community (0:
    // none, as in the paper).
    int image_overlap = 3;

    // Communities reconstructed at once (-1: one per CPU core, at most one
    // per community); the threads are split evenly among them.
    int num_workers = -1;

    // Relative function tolerance of the communities' global adjustments and
    // the merged model's refinement (-1: the incremental mapper's
    // ba_global_function_tolerance); a plan of one community runs the mapper's.
    double ba_function_tolerance = 1e-6;

    // The merge (community_merger.h); MergeOptions() sets its inputs,
    // min_num_matches, incremental_options and tolerance from this struct.
    CommunityMergerOptions merge;

    // The incremental mapper's, per community and for the merge; its
    // min_num_matches is the view graph's too.
    IncrementalPipelineOptions incremental_options;

    CommunityMergerOptions MergeOptions() const;

    // incremental_options for one community's images (sorted), with
    // image_path, `num_threads` where it leaves them to the machine, and
    // ba_function_tolerance unless it is the plan's `only_community`.
    IncrementalPipelineOptions CommunityIncrementalOptions(
        const std::unordered_set<std::string>& image_names,
        int num_threads,
        bool only_community = false) const;

    bool Check() const;
  };

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

  // Stage 3 (CommunityMerger::Solve): merges the plan's communities, from
  // their models and records on disk, into reconstruction_manager (largest
  // first) and writes communities.ply. False if the plan does not fit, or
  // communities have no record yet (they are named).
  bool Merge();

  // All three stages; where the output folder holds a plan that fits, the
  // partition is read from it and communities with a record are reused.
  // False if a stage failed (logged).
  bool RunAllStages();

  void Run() override { RunAllStages(); }

  // What happened (community_mapper_summary.h).
  const CommunityMapperSummary& GetSummary() const { return summary_; }

 private:
  // Reads the plan and checks that it fits this run; logs why not.
  bool LoadPlan();
  // Copies the plan's figures (modularity, community sizes) to the summary.
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
  CommunityMapperSummary summary_;
};

}  // namespace colmap
