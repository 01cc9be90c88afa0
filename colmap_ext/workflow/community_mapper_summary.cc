#include "colmap_ext/workflow/community_mapper_summary.h"

#include "colmap/util/logging.h"
#include "colmap/util/misc.h"
#include "colmap/util/string.h"

namespace colmap {

std::string SpaceSeparated(const std::vector<int>& values) {
  std::string text;
  for (const int value : values) {
    text += " " + std::to_string(value);
  }
  return text;
}

std::string CommunityMapperSummaryToText(
    const CommunityMapperSummary& summary) {
  std::string text =
      "# Figures of a community_mapper run (key value; seconds, MB)\n";
  text +=
      StringPrintf("num_view_graph_images %d\n", summary.num_view_graph_images);
  text += StringPrintf("max_modularity %.4f\n", summary.max_modularity);
  text += StringPrintf("num_communities %d\n",
                       static_cast<int>(summary.community_sizes.size()));
  text += "community_sizes" + SpaceSeparated(summary.community_sizes) + "\n";
  text += "extra_community_origins" +
          SpaceSeparated(summary.extra_community_origins) + "\n";
  text += "reconstructed_communities" +
          SpaceSeparated(summary.reconstructed_communities) + "\n";
  text +=
      "reused_communities" + SpaceSeparated(summary.reused_communities) + "\n";
  text += StringPrintf("num_community_pairs %d\n", summary.num_community_pairs);
  text += StringPrintf("num_estimated_similarities %d\n",
                       summary.num_estimated_similarities);
  text +=
      StringPrintf("num_kept_similarities %d\n", summary.num_kept_similarities);
  text += "model_num_registered" +
          SpaceSeparated(summary.model_num_registered) + "\n";
  for (const auto& phase : summary.phase_seconds) {
    std::string name = StringReplace(phase.first, " ", "_");
    StringToLower(&name);
    text += StringPrintf("phase_seconds %s %.3f\n", name.c_str(), phase.second);
  }
  text += StringPrintf("peak_memory_mb %.1f\n", summary.peak_memory_mb);
  return text;
}

void LogCommunityMapperSummary(const CommunityMapperSummary& summary) {
  LOG_HEADING1("Community mapper summary");
  for (size_t c = 0; c < summary.community_sizes.size() &&
                     c < summary.community_reports.size();
       ++c) {
    const CommunityModelReport& report = summary.community_reports[c];
    LOG(INFO) << StringPrintf(
        "Community %d: %d images, %d registered%s",
        static_cast<int>(c),
        summary.community_sizes[c],
        report.num_registered,
        report.num_models > 1 ? " (largest of several models)" : "");
  }
  for (size_t e = 0; e < summary.extra_community_origins.size(); ++e) {
    const size_t c = summary.community_sizes.size() + e;
    LOG(INFO) << StringPrintf(
        "Community %d (model %d of community %d): %d registered",
        static_cast<int>(c),
        summary.community_reports[c].model_index,
        summary.extra_community_origins[e],
        summary.community_reports[c].num_registered);
  }
  LOG(INFO) << StringPrintf(
      "Community pairs: %d joined by view-graph edges, %d with a similarity, "
      "%d kept, %d dropped",
      summary.num_community_pairs,
      summary.num_estimated_similarities,
      summary.num_kept_similarities,
      summary.num_estimated_similarities - summary.num_kept_similarities);
  LOG_IF(INFO, !summary.reused_communities.empty())
      << "Communities reused from an earlier run of this plan:"
      << SpaceSeparated(summary.reused_communities);
  int num_registered = 0;
  for (size_t m = 0; m < summary.model_num_registered.size(); ++m) {
    LOG(INFO) << StringPrintf("Model %d: %d images",
                              static_cast<int>(m),
                              summary.model_num_registered[m]);
    num_registered += summary.model_num_registered[m];
  }
  LOG(INFO) << StringPrintf(
      "Registered %d of %d images in %d model(s)",
      num_registered,
      summary.num_view_graph_images,
      static_cast<int>(summary.model_num_registered.size()));
  for (const auto& phase : summary.phase_seconds) {
    LOG(INFO) << StringPrintf(
        "Time %-28s %9.3fs", (phase.first + ":").c_str(), phase.second);
  }
  LOG(INFO) << StringPrintf("Peak memory: %.0f MB", summary.peak_memory_mb);
}

}  // namespace colmap
