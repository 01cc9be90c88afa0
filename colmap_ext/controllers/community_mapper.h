// Community-based Structure from Motion (CSfM).
//
// Cui, Shen, Gao and Hu, "CSfM: Community-based Structure from Motion",
// ICIP 2017. The view graph of the database is split into communities of
// images with dense connections inside and sparse ones outside (greedy
// modularity, recursive, small communities merged); every community is
// reconstructed on its own, in parallel, by COLMAP's incremental mapper; the
// community models are brought into one frame by global similarity
// averaging (L1 scale, L1RA rotation and L1 translation averaging of the
// pairwise similarities between connected communities) and merged, and a
// final bundle adjustment refines the whole model.
//
// Compared with COLMAP's HierarchicalMapperController, which partitions by
// METIS into overlapping clusters and merges them pair by pair, the
// partition follows the view graph's own structure, the merge is global and
// judges what it merges, and the merged model is bundle adjusted.
//
// Where the merge cannot join communities (no similarity found, or one it
// does not trust), it still gives what the incremental mapper would: the
// images of a part that no similarity joins to a larger one are offered to
// the larger part's refinement, which registers those it can, and a
// community that left the merge keeps the images nobody registered as a
// model of its own; no image is written in two models.
//
// The work is done in three stages over files in the output folder
// (community_workspace.h), each a method that another process, or a
// cluster's job, can run alone: Partition(), ReconstructCommunity(K) for
// every community, Merge(). Run() does all three in one process and resumes
// an earlier run of the same plan: the communities that have a record are
// not reconstructed again.

#pragma once

#include "colmap_ext/graph/community_detection.h"
#include "colmap_ext/graph/view_graph.h"
#include "colmap_ext/scene/community_workspace.h"
#include "colmap_ext/sfm/community_judgement.h"
#include "colmap_ext/sfm/community_merger.h"
#include "colmap_ext/sfm/covisibility_check.h"
#include "colmap_ext/sfm/pairwise_similarity.h"
#include "colmap_ext/sfm/pose_graph_alignment.h"
#include "colmap_ext/sfm/similarity_averaging.h"

#include "colmap/controllers/incremental_mapper.h"
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
    // database), as colmap mapper's --image_list_path: the view graph holds
    // the pairs of two of them. The command records the list in
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

    // Minimum number of verified inlier matches for a view-graph edge;
    // -1 takes the incremental mapper's min_num_matches.
    int min_num_matches = -1;

    // Edge weights for community detection: every edge 1, as in the paper,
    // or its verified inlier count. The balance rule splits the unit graph
    // of an exhaustively matched database too (README: edge_weights).
    ViewGraphEdgeWeight edge_weight = ViewGraphEdgeWeight::kUnit;

    // Number of images each community borrows from each neighbouring
    // community, so that neighbours share images and points for the
    // pairwise similarities (0: communities share nothing, as in the paper,
    // and only the matches of cross edges link them). Measured on a
    // generated scene of 1000 images in 6 communities: with 3, the pairwise
    // similarities had 2-4x as many inliers (e.g. 216 of 259 correspondences
    // instead of 39 of 79), and one more neighbour pair was usable (628
    // inliers instead of 3), for the same time and accuracy.
    int image_overlap = 3;

    // Stop after the partition (communities.txt), before reconstructing.
    bool partition_only = false;

    // Number of communities reconstructed at the same time; -1: as many as
    // there are CPU cores (at most the number of communities). The threads
    // are split evenly among the workers.
    int num_workers = -1;

    // Relative function tolerance of the global bundle adjustments inside
    // each community's incremental mapper; -1 takes
    // incremental_options.ba_global_function_tolerance (COLMAP's default 0
    // runs every global adjustment to its iteration limit). The merged model
    // is bundle adjusted as a whole at the end, so the communities need not
    // polish the last digits: on a generated scene of 1000 images, 1e-6
    // made the communities' reconstruction 17% faster.
    double community_ba_function_tolerance = 1e-6;

    // Growth of a community's model (in registered images or in points)
    // after which its incremental mapper runs the next global bundle
    // adjustment; -1 takes incremental_options.ba_global_images_ratio and
    // ba_global_points_ratio (COLMAP's 1.1). Local bundle adjustment still
    // follows every registration, and the merged model is adjusted as a
    // whole at the end. Measured with 1.4 instead of 1.1, on a generated
    // scene of 1000 images in 6 communities: communities 24% faster, same
    // accuracy; on one of 530 images with a camera per image and no loop:
    // 17% faster, same accuracy, 529 instead of 530 images registered.
    double community_ba_global_ratio = 1.4;

    // A community most of whose images have a camera of their own (as
    // photos from many devices, or per-image intrinsics) runs the incremental
    // mapper's own global adjustments (incremental_options'
    // ba_global_function_tolerance and ratios) instead of the two cheaper
    // settings above: its intrinsics are estimated image by image, and a
    // short walkway piece of such images, reconstructed alone, comes out
    // bent where fewer and shorter global adjustments leave it. Measured on
    // generated open chains of 500 images with a camera per image (seeds 3,
    // 5, 6): median camera error 0.225 / 0.643 / 0.685 with the cheaper
    // settings, 0.178 / 0.249 / 0.520 with the mapper's (colmap mapper:
    // 0.130 / 0.286 / 0.497); each of the two settings alone changed little
    // (0.616, 0.636 on seed 5). The whole run took as long (107.6 s against
    // 107-117 s on seed 3): the communities took 87 s instead of 59-68 s, the
    // refinement less from their better start.
    bool mapper_schedule_for_own_cameras = true;

    // Whether a community gets the mapper's own schedule: where
    // mapper_schedule_for_own_cameras applies to it (its images have a
    // camera of their own in this fraction), or where it is the plan's only
    // community. A single community is not merged, so no adjustment of the
    // whole follows the cheaper schedule: its model is the result, and
    // would be a little less accurate than colmap mapper's (castle-P30,
    // stop 30: median camera error 0.1551 against 0.1544 m in 0.82 of the
    // time).
    bool UsesMapperSchedule(double own_camera_fraction,
                            bool only_community = false) const;

    // Where a community's mapper made several models, each other model
    // that holds at least incremental_options.min_model_size of the
    // community's own images (that no larger model of it holds) takes part
    // in the merge as an extra community; false: only the largest does, and
    // the refinement registers the others' images one by one (each with a
    // local bundle adjustment). Merge-stage option: the community stage
    // writes the other models either way.
    bool merge_other_models = true;

    // Pairwise similarity estimation between connected communities.
    PairwiseSimilarityOptions pairwise_similarity;

    // The check that an alignment explains which images were matched.
    CovisibilityCheckOptions covisibility_check;

    // A similarity that the co-visibility check rejected, between two
    // communities that the averaging joins through other links, was right
    // where it lies within the averaging's residual bounds of that placement
    // (ResidualsAgainstMerge in community_alignment.h): its cross pairs stay
    // in the refinement instead of being left out as false pairs, and close
    // the loop there. False: every rejected similarity's pairs are left out.
    bool confirm_rejected_links = true;

    // The rotation and translation bounds that confirm a rejected
    // similarity grow with the drift the links between its communities may
    // have accumulated: times the square root of the number of links on the
    // path (their effective resistance), at most this factor (1: the
    // averaging's bounds alone). Two identical facades matched onto each
    // other lie several spreads apart; a facade of repeated windows matched
    // one period off, a fraction of a spread (see community_alignment.h).
    double rejected_link_max_drift_factor = 1.5;

    // Where a community that the averaging left in a part apart has two
    // rejected similarities to two different communities of another part,
    // resting on different points of it, the averaging is run again with
    // them (JoinPartsByRejectedLinks in community_alignment.h): if it
    // keeps both, and every link it kept before, without sending any
    // community out of the merge, the two parts are one (the similarities'
    // pairs stay in the refinement); otherwise the first averaging stands.
    // Only similarities that the check refused by wide views alone count
    // (no close view predicted across, CovisibilityCheckOptions::
    // close_ray_angle_deg). Off by default: an identical building whose
    // photographs fell into two communities, photographed from other places
    // than its twin, can still place a community alike twice
    // (community_alignment.h), and a wrong merge is worse than two models.
    // On South Building resized to 384 px it joins a community cut off by
    // the check (one model of 128 images instead of 100 + 28); on every
    // other database measured it changes nothing (stop 44).
    bool join_parts_by_rejected_links = false;

    // What makes a community's own model doubtful.
    CommunityJudgementOptions judgement;

    // Global similarity averaging and edge rejection.
    SimilarityAveragingOptions similarity_averaging;

    // Before the refinement, a scale-drift-aware pose graph over the
    // communities' cameras spreads each community's disagreement with its
    // neighbours over its edges (pose_graph_alignment.h). Off by default:
    // its ties are the copies of the images that neighbours borrow, placed
    // at the edge of the borrowing community, and where they pull against
    // the similarities from thousands of shared points they bend the
    // communities rather than straighten them. Merge stage reruns on the
    // benchmark's communities, median / 90th-percentile camera error after
    // the refinement, off / on: 2940-image open chain of landmarks 0.162 /
    // 0.352 and 0.181 / 0.427; 500-image open chain with a camera per image
    // 0.226 / 0.719 and 0.250 / 0.666; courtyard loop 0.0147 / 0.0277 and
    // 0.0152 / 0.0282; South Building 0.0116 / 0.0485 and 0.0119 / 0.0481;
    // medium loop and dense scene the same either way. Before the
    // refinement, the 9990-image open chain's cameras were 2.97 / 5.17 off
    // as joined and 3.86 / 8.00 after the pose graph.
    bool align_pose_graph = false;
    PoseGraphAlignmentOptions pose_graph;

    // Refinement of the merged model.
    MergedModelRefinementOptions refinement;

    // Options of the incremental mapper (per community, and for the
    // registration, triangulation and bundle adjustment of the merge).
    IncrementalMapperOptions incremental_options;

    // The minimum number of matches in effect.
    int MinNumMatches() const;

    // The incremental mapper's options for one community's images:
    // incremental_options with the community_* settings above in effect
    // (unless UsesMapperSchedule(own_camera_fraction, only_community)),
    // and num_threads threads if incremental_options leaves it to the
    // machine.
    IncrementalMapperOptions CommunityIncrementalOptions(
        const std::unordered_set<std::string>& image_names,
        int num_threads,
        double own_camera_fraction = 0,
        bool only_community = false) const;

    bool Check() const;
  };

  // What happened, for the log's final summary and for tests.
  struct Summary {
    int num_view_graph_images = 0;
    int num_view_graph_edges = 0;
    int num_view_graph_components = 0;
    double max_modularity = 0.0;
    // Per community of the plan: its own images.
    std::vector<int> community_sizes;
    // Per community of the merge (the plan's, then the extra communities:
    // other models of a community's mapper, see Merge()): what its mapper
    // produced, the verdict on its model, and whether it left the merge
    // (its images were then offered to the merged model, and those it did
    // not register kept the community's model unless it was broken).
    std::vector<CommunityModelReport> community_reports;
    std::vector<CommunityJudgement> community_judgements;
    std::vector<bool> community_excluded;
    // The plan's community each extra community comes from.
    std::vector<int> extra_community_origins;
    // Pairs of communities joined by view-graph edges, with a pairwise
    // similarity, and kept by the averaging.
    int num_community_pairs = 0;
    int num_estimated_similarities = 0;
    int num_kept_similarities = 0;
    // Communities reconstructed by this run, and those reused from an
    // earlier run of the same plan.
    std::vector<int> reconstructed_communities;
    std::vector<int> reused_communities;
    // Final models (largest first): registered images of each.
    std::vector<int> model_num_registered;
    // Community of the plan of every image of the view graph (an extra
    // community's images are its origin's: communities.ply colours them so).
    std::unordered_map<image_t, int> community_of_image;
    // Phase name and seconds.
    std::vector<std::pair<std::string, double>> phase_seconds;
    // Peak resident memory of the process (MB).
    double peak_memory_mb = 0.0;
  };

  // The summary as "key value" lines (OUT/summary.txt), for scripts such as
  // the benchmark: phase_seconds NAME SECONDS (NAME in snake case),
  // community_sizes (the plan's), extra_community_origins,
  // num_excluded_communities (of the plan's and the extra ones),
  // reused_communities, model_num_registered, peak_memory_mb, ...
  static std::string SummaryToText(const Summary& summary);

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

  // Stage 3: merges the communities of the plan from their models and
  // records on disk into reconstruction_manager (largest first) and writes
  // communities.ply. Where a community's mapper made several models, the
  // others that hold enough of its images take part as extra communities.
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

  const Options options_;
  const CommunityWorkspace workspace_;
  std::shared_ptr<ReconstructionManager> reconstruction_manager_;
  std::string database_fingerprint_;
  CommunityPlan plan_;
  bool has_plan_ = false;
  Summary summary_;
};

}  // namespace colmap
