#include "colmap_ext/exe/community_mapper_options.h"

#include "colmap_ext/testing/testing.h"
#include "colmap_ext/workflow/community_workspace.h"

#include <filesystem>
#include <set>

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(CommunityMapperOptionTable, NamesAreUniqueAndFew) {
  CommunityMapperCommandOptions options;
  const std::vector<CommunityMapperOption> table =
      CommunityMapperOptionTable(&options);
  std::set<std::string> names;
  int num_user_options = 0;
  bool advanced_seen = false;
  for (const CommunityMapperOption& option : table) {
    EXPECT_TRUE(names.insert(option.name).second) << option.name;
    EXPECT_FALSE(option.help.empty()) << option.name;
    // Users' options come first.
    EXPECT_TRUE(option.advanced || !advanced_seen) << option.name;
    advanced_seen = advanced_seen || option.advanced;
    num_user_options += option.advanced ? 0 : 1;
  }
  EXPECT_LE(table.size(), 15);
  EXPECT_LE(num_user_options, 12);
}

TEST(CommunityMapperOptionTable, BindsTheFields) {
  CommunityMapperCommandOptions options;
  for (const CommunityMapperOption& option :
       CommunityMapperOptionTable(&options)) {
    if (option.name == "min_community_size") {
      *option.int_value = 7;
    } else if (option.name == "averaging_max_relative_displacement") {
      *option.double_value = 0.35;
    } else if (option.name == "edge_weights") {
      *option.string_value = "num_inliers";
    } else if (option.name == "overwrite") {
      *option.bool_value = true;
    }
  }
  EXPECT_EQ(options.mapper.community_detection.min_community_size, 7);
  EXPECT_EQ(options.mapper.merge.similarity_averaging.max_relative_displacement,
            0.35);
  EXPECT_EQ(options.edge_weights, "num_inliers");
  EXPECT_TRUE(options.overwrite);
  // The ini section has the values, but not overwrite (a saved project must
  // not replace results).
  const std::string ini = CommunityMapperIniSection(options);
  EXPECT_EQ(ini.rfind("[CommunityMapper]\n", 0), 0);
  EXPECT_NE(ini.find("\nmin_community_size=7\n"), std::string::npos) << ini;
  EXPECT_NE(ini.find("\naveraging_max_relative_displacement=0.35\n"),
            std::string::npos);
  EXPECT_NE(ini.find("\nedge_weights=num_inliers\n"), std::string::npos);
  EXPECT_EQ(ini.find("overwrite"), std::string::npos);
}

TEST(CommunityMapperOptionTable, PlanKeysAreThePartitionsAndCommunities) {
  const std::vector<std::string> keys = CommunityMapperPlanKeys();
  const std::set<std::string> key_set(keys.begin(), keys.end());
  for (const std::string key : {"modularity_threshold",
                                "min_community_size",
                                "edge_weights",
                                "image_overlap"}) {
    EXPECT_EQ(key_set.count(key), 1) << key;
  }
  // The merge's and the run's own options may differ between runs of one
  // plan.
  for (const std::string key :
       {"num_workers", "overwrite", "pairwise_min_num_inliers",
        "skip_global_refinement", "skip_registration"}) {
    EXPECT_EQ(key_set.count(key), 0) << key;
  }
}

// docs/options.md is the table's (regenerate it with
// build/community_mapper_options_doc > docs/options.md).
TEST(CommunityMapperOptionsMarkdown, IsTheDocsFile) {
  const std::string doc = ReadTextFile(
      (std::filesystem::path(SOURCE_DIR) / "docs" / "options.md").string());
  EXPECT_EQ(CommunityMapperOptionsMarkdown(), doc)
      << "docs/options.md is out of date: run "
         "build/community_mapper_options_doc > docs/options.md";
}

}  // namespace
}  // namespace colmap
