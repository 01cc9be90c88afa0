#include "colmap_ext/exe/community_mapper_options.h"

#include "colmap_ext/workflow/atomic_output.h"

#include "colmap/util/file.h"

#include <filesystem>
#include <sstream>

namespace colmap {

std::string CommunityMapperOption::ValueToText() const {
  std::ostringstream text;
  Visit([&text](const auto* field) { text << *field; });
  return text.str();
}

std::vector<CommunityMapperOption> CommunityMapperOptionTable(
    CommunityMapperCommandOptions* options) {
  CommunityMapperController::Options& mapper = options->mapper;
  CommunityDetectionOptions& detection = mapper.community_detection;
  CommunityMergerOptions& merge = mapper.merge;
  SimilarityAveragingOptions& averaging = merge.similarity_averaging;
  const bool kShapesPlan = true;
  const bool kAdvanced = true;
  return {
      // The options users set.
      {"modularity_threshold",
       &detection.modularity_threshold,
       "split a view (sub)graph into communities only where its peak "
       "modularity Qmax exceeds this (the CSfM paper: 0.3)",
       kShapesPlan},
      {"min_community_size",
       &detection.min_community_size,
       "communities with fewer images join their most connected neighbour "
       "(the CSfM paper: 20)",
       kShapesPlan},
      {"max_community_fraction",
       &detection.max_community_fraction,
       "below 1, a (sub)graph holding more than this fraction of its "
       "connected component is split at its modularity peak even below the "
       "threshold, once per branch, for parallel work on a scene without "
       "structure (1: the threshold only, as the paper)",
       kShapesPlan},
      {"edge_weights",
       &options->edge_weights,
       "view-graph edge weights for community detection: unit (the paper) "
       "or num_inliers (verified inlier matches)",
       kShapesPlan},
      {"image_overlap",
       &mapper.image_overlap,
       "images each community borrows from each neighbouring community, so "
       "that their models share points (0: none, as in the paper)",
       kShapesPlan},
      {"num_workers",
       &mapper.num_workers,
       "communities reconstructed at once (-1: one per CPU core)"},
      {"skip_global_refinement",
       &merge.skip_global_refinement,
       "the merge's stage 3 off: each part's joined model goes to the "
       "registration as the similarity averaging placed it, without its "
       "retriangulation and robust adjustment"},
      {"skip_registration",
       &merge.skip_registration,
       "the merge's stage 4 off: the images no community registered stay "
       "unregistered, and parts no link joins stay models of their own"},
      {"overwrite",
       &options->overwrite,
       "replace the results of an earlier run in output_path instead of "
       "resuming it (community_reconstructor: reconstruct the community "
       "again)",
       false,
       false,
       /*saved=*/false},

      // Advanced options, prefixed by their stage.
      {"partition_max_part_conductance",
       &detection.max_part_conductance,
       "a split above the modularity threshold is refused where a part has "
       "more than this share of its edges to the other parts (1: the "
       "threshold only)",
       kShapesPlan,
       kAdvanced},
      {"ba_function_tolerance",
       &mapper.ba_function_tolerance,
       "relative function tolerance at which the global bundle adjustments "
       "of the communities and the merged model's refinement stop (-1: "
       "Mapper.ba_global_function_tolerance; a plan of one community runs "
       "the mapper's own)",
       kShapesPlan,
       kAdvanced},
      {"pairwise_max_relative_error",
       &merge.pairwise_similarity.max_relative_error,
       "RANSAC inlier threshold of the similarity between two communities, "
       "as a fraction of the spread of their co-visible points",
       false,
       kAdvanced},
      {"pairwise_min_num_inliers",
       &merge.pairwise_similarity.min_num_inliers,
       "inlier point correspondences a similarity between two communities "
       "needs to be used",
       false,
       kAdvanced},
      {"covisibility_min_rate_ratio",
       &merge.covisibility_check.min_rate_ratio,
       "reject a similarity under which the image pairs it makes co-visible "
       "were verified less often than this fraction of the rate inside the "
       "communities (0: no check)",
       false,
       kAdvanced},
      {"averaging_max_relative_displacement",
       &averaging.max_relative_displacement,
       "drop a similarity between two communities if the averaging places "
       "the two copies of its inlier points further apart than this fraction "
       "of their spread (median)",
       false,
       kAdvanced},
  };
}

void AddCommunityMapperOptions(CommunityMapperCommandOptions* options,
                               OptionManager* option_manager) {
  for (const CommunityMapperOption& option :
       CommunityMapperOptionTable(options)) {
    option.Visit([&](auto* field) {
      option_manager->AddDefaultOption(
          "CommunityMapper." + option.name, field, option.help);
    });
  }
}

std::string CommunityMapperIniSection(
    const CommunityMapperCommandOptions& options) {
  CommunityMapperCommandOptions copy = options;
  std::string section = "[CommunityMapper]\n";
  for (const CommunityMapperOption& option :
       CommunityMapperOptionTable(&copy)) {
    if (option.saved) {
      section += option.name + "=" + option.ValueToText() + "\n";
    }
  }
  return section;
}

std::vector<std::string> CommunityMapperPlanKeys() {
  CommunityMapperCommandOptions defaults;
  std::vector<std::string> keys;
  for (const CommunityMapperOption& option :
       CommunityMapperOptionTable(&defaults)) {
    if (option.shapes_plan) {
      keys.push_back(option.name);
    }
  }
  return keys;
}

std::string PlanOptionsFromIni(const std::string& project_ini) {
  const std::vector<std::string> plan_keys = CommunityMapperPlanKeys();
  const std::set<std::string> community_mapper_keys(plan_keys.begin(),
                                                    plan_keys.end());
  static const std::set<std::string> kIgnoredMapperKeys = {
      "num_threads", "ba_gpu_index", "snapshot_path", "snapshot_frames_freq"};
  std::string plan_options;
  std::string section;
  std::istringstream lines(project_ini);
  std::string line;
  while (std::getline(lines, line)) {
    if (!line.empty() && line[0] == '[') {
      section = line.substr(1, line.find(']') - 1);
      continue;
    }
    const size_t equals = line.find('=');
    if (equals == std::string::npos) {
      continue;
    }
    const std::string key = line.substr(0, equals);
    if ((section == "Mapper" && kIgnoredMapperKeys.count(key) == 0) ||
        (section == "CommunityMapper" && community_mapper_keys.count(key))) {
      plan_options += section + "." + line + "\n";
    }
  }
  return plan_options;
}

std::string ColmapOptionsToIni(const OptionManager& options,
                               const std::set<std::string>& own_keys) {
  const std::filesystem::path temporary =
      std::filesystem::temp_directory_path() /
      ("community_mapper-" + WriterTag() + ".ini");
  options.Write(temporary);
  const std::vector<std::string> lines = ReadTextFileLines(temporary);
  std::filesystem::remove(temporary);
  std::string text;
  std::string section;
  for (const std::string& line : lines) {
    if (line[0] == '[') {
      section = line.substr(1, line.find(']') - 1);
    }
    const bool own = section.empty()
                         ? own_keys.count(line.substr(0, line.find('='))) > 0
                         : section == "CommunityMapper";
    if (!own) {
      text += line + "\n";
    }
  }
  return text;
}

}  // namespace colmap
