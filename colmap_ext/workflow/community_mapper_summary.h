// What a community_mapper run did: the figures of its log's closing summary
// and of OUT/summary.txt.
#pragma once

#include "colmap_ext/merge/community_merger.h"

#include "colmap/util/types.h"

#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace colmap {

// What happened, for the log's final summary and for tests.
struct CommunityMapperSummary {
  int num_view_graph_images = 0;
  int num_view_graph_edges = 0;
  int num_view_graph_components = 0;
  double max_modularity = 0.0;
  // Per community of the plan: its own images.
  std::vector<int> community_sizes;
  // Per community of the merge (the plan's, then the extra communities:
  // other models of a community's mapper, see Merge()): what its mapper
  // produced.
  std::vector<CommunityModelReport> community_reports;
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
// reused_communities, model_num_registered, peak_memory_mb, ...
std::string CommunityMapperSummaryToText(const CommunityMapperSummary& summary);

// Logs the closing summary of a run.
void LogCommunityMapperSummary(const CommunityMapperSummary& summary);

}  // namespace colmap
