// What a community_mapper run did: the figures of its log's closing summary
// and of OUT/summary.txt.
#pragma once

#include "colmap_ext/merge/community_merger.h"

#include <string>
#include <utility>
#include <vector>

namespace colmap {

// The merge's result (community_merger.h; its view-graph figures are set by
// the partition too) and the run's own figures.
struct CommunityMapperSummary : public CommunityMergerResult {
  double max_modularity = 0.0;
  // Per community of the plan: its own images.
  std::vector<int> community_sizes;
  // Communities reconstructed by this run, and those reused from an
  // earlier run of the same plan.
  std::vector<int> reconstructed_communities;
  std::vector<int> reused_communities;
  // Final models (largest first): registered images of each.
  std::vector<int> model_num_registered;
  // Phase name and seconds (the merge's stages among them).
  std::vector<std::pair<std::string, double>> phase_seconds;
  // Peak resident memory of the process (MB).
  double peak_memory_mb = 0.0;
};

// The values, each after a space: " 1 2 3".
std::string SpaceSeparated(const std::vector<int>& values);

// The summary as "key value" lines (OUT/summary.txt), for scripts such as
// the benchmark: phase_seconds NAME SECONDS (NAME in snake case),
// community_sizes (the plan's), extra_community_origins,
// reused_communities, model_num_registered, peak_memory_mb, ...
std::string CommunityMapperSummaryToText(const CommunityMapperSummary& summary);

// Logs the closing summary of a run.
void LogCommunityMapperSummary(const CommunityMapperSummary& summary);

}  // namespace colmap
