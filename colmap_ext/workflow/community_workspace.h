// The output folder (OUT) of the community mapper and its stages.
//
// Three stages, each reading only what the one before wrote, so that a
// killed run resumes and a cluster's scheduler can run communities as jobs:
//   1. partition:    OUT/plan.txt, OUT/communities.txt
//   2. community K:  OUT/communities/K/ (its largest model; the others as
//                    K.1/, K.2/, ...), then OUT/communities/K.done (its record)
//   3. merge:        OUT/0/, OUT/1/, ... (largest first), OUT/communities.ply,
//                    OUT/project.ini, OUT/summary.txt (figures, for scripts)
// Every file and model is written atomically (atomic_output.h), a record
// after its model. The plan holds the database (path and fingerprint), the
// options in effect and every community's own and borrowed images.
// docs/design.md, Outputs and workflow, gives the reasons.

#pragma once

#include "colmap/scene/database.h"
#include "colmap/scene/reconstruction.h"

#include <memory>
#include <string>
#include <vector>

namespace colmap {

class CommunityWorkspace {
 public:
  explicit CommunityWorkspace(std::string output_path);

  const std::string& OutputPath() const { return output_path_; }
  std::string PlanPath() const { return Join("plan.txt"); }
  std::string CommunitiesPath() const { return Join("communities.txt"); }
  std::string CommunitiesDir() const { return Join("communities"); }
  std::string CommunityModelPath(int community_id) const {
    return Join("communities/" + std::to_string(community_id));
  }
  // The mapper's other models of the community: index 1 is the second
  // largest, and so on.
  std::string CommunityOtherModelPath(int community_id, int index) const {
    return Join("communities/" + std::to_string(community_id) + "." +
                std::to_string(index));
  }
  std::string CommunityRecordPath(int community_id) const {
    return Join("communities/" + std::to_string(community_id) + ".done");
  }
  std::string MergedModelPath(int model_index) const {
    return Join(std::to_string(model_index));
  }
  std::string CommunitiesPlyPath() const { return Join("communities.ply"); }
  std::string ProjectPath() const { return Join("project.ini"); }
  std::string SummaryPath() const { return Join("summary.txt"); }

  // Whether OUT holds results of a run (a plan, a partition, communities or
  // merged models).
  bool HasResults() const;

  // Creates OUT if needed and checks that it is a writable folder; the
  // problem (naming what to do about it) if not, else empty.
  std::string CreateOutputFolder() const;

  // Removes every result of an earlier run (for --overwrite).
  void RemoveResults() const;

  // Removes community K's models and record (to reconstruct it again).
  void RemoveCommunity(int community_id) const;

  // Writes the merged models as OUT/0, OUT/1, ... (each atomically) and
  // removes numbered models of an earlier run beyond them.
  void WriteMergedModels(
      const std::vector<std::shared_ptr<const Reconstruction>>& models) const;

  // The numbered merged models in OUT (0, 1, ...).
  std::vector<std::string> MergedModelPaths() const;

 private:
  // OUT/name.
  std::string Join(const std::string& name) const;

  std::string output_path_;
};

struct CommunityPlan {
  struct Community {
    std::vector<std::string> own_image_names;
    std::vector<std::string> borrowed_image_names;
  };

  std::string database_path;
  std::string database_fingerprint;
  // "key=value" lines of the options that shape the result.
  std::string options;
  std::vector<Community> communities;
  // The partition's figures, kept for a run that reuses the plan.
  double max_modularity = 0.0;
  int num_view_graph_components = 0;

  int NumCommunities() const { return static_cast<int>(communities.size()); }
};

std::string CommunityPlanToText(const CommunityPlan& plan);

// Parses a plan; throws std::invalid_argument naming what is malformed.
CommunityPlan CommunityPlanFromText(const std::string& text);

// A fingerprint (hex) of the database's cameras, images, rigs, frames and
// verified pairs (their inlier counts): what the partition and the
// communities depend on.
std::string DatabaseFingerprint(const Database& database);

// A fingerprint (hex) of the texts, in their order (e.g. an image list).
std::string TextsFingerprint(const std::vector<std::string>& texts);

// Why `plan` does not fit the database fingerprint and options of this run
// (empty if it fits): the first option that differs, or the database.
std::string PlanMismatch(const CommunityPlan& plan,
                         const std::string& database_fingerprint,
                         const std::string& options);

// What a community's reconstruction produced (stage 2's record).
struct CommunityRecord {
  int community_id = -1;
  // Images given to its mapper (its own and those it borrowed).
  int num_images = 0;
  // Registered images of its largest model (0: no model).
  int num_registered = 0;
  int num_points = 0;
  int num_models = 0;
  // Of the other models, those written beside the largest (the ones of at
  // least Mapper.min_model_size images: K.1, K.2, ...).
  int num_other_models = 0;
  double mean_reprojection_error = 0.0;
  double seconds = 0.0;
  // The plan's database fingerprint, so that a record of another plan is
  // never taken for this one's.
  std::string database_fingerprint;
};

std::string CommunityRecordToText(const CommunityRecord& record);
// One line for the log: how the community came out, or that it could not be
// reconstructed and takes no part in the merge.
std::string DescribeCommunityRecord(const CommunityRecord& record);
CommunityRecord CommunityRecordFromText(const std::string& text);

// Reads the text file; throws if it cannot be read.
std::string ReadTextFile(const std::string& path);

}  // namespace colmap
