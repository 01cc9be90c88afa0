#include "colmap_ext/workflow/community_mapper.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

// A community runs the user's --Mapper.* settings on its own images.
TEST(CommunityIncrementalOptions, AreTheMappersOnTheCommunitysImages) {
  CommunityMapperController::Options options;
  options.incremental_options.mapper.ba_local_num_images = 9;
  options.incremental_options.ba_global_frames_ratio = 1.3;
  const IncrementalPipelineOptions community_options =
      options.CommunityIncrementalOptions({"b.jpg", "a.jpg"},
                                          /*num_threads=*/3);
  EXPECT_EQ(community_options.image_names,
            std::vector<std::string>({"a.jpg", "b.jpg"}));
  EXPECT_EQ(community_options.num_threads, 3);
  EXPECT_EQ(community_options.mapper.ba_local_num_images, 9);
  EXPECT_EQ(community_options.ba_global_frames_ratio, 1.3);
  EXPECT_TRUE(community_options.Check());
}

// The global adjustments of the communities and the merged model's
// refinement stop at ba_function_tolerance; a plan of one community, or -1,
// runs the mapper's own. The registration into the merged model is the
// user's mapper, at the user's tolerance.
TEST(CommunityIncrementalOptions,
     GlobalAdjustmentsStopAtTheCommunityTolerance) {
  CommunityMapperController::Options options;
  options.incremental_options.ba_global_function_tolerance = 1e-9;
  options.ba_function_tolerance = 1e-5;
  EXPECT_EQ(options.CommunityIncrementalOptions({"a.jpg"}, 1)
                .ba_global_function_tolerance,
            1e-5);
  EXPECT_EQ(options.MergeOptions().refinement_function_tolerance, 1e-5);
  EXPECT_EQ(
      options.MergeOptions().incremental_options.ba_global_function_tolerance,
      1e-9);
  EXPECT_EQ(
      options.CommunityIncrementalOptions({"a.jpg"}, 1, /*only_community=*/true)
          .ba_global_function_tolerance,
      1e-9);
  options.ba_function_tolerance = -1;
  EXPECT_EQ(options.CommunityIncrementalOptions({"a.jpg"}, 1)
                .ba_global_function_tolerance,
            1e-9);
  EXPECT_EQ(options.MergeOptions().refinement_function_tolerance, 1e-9);
}

// A thread count the user sets is kept.
TEST(CommunityIncrementalOptions, KeepTheUsersThreadCount) {
  CommunityMapperController::Options options;
  options.incremental_options.num_threads = 5;
  EXPECT_EQ(options.CommunityIncrementalOptions({"a.jpg"}, /*num_threads=*/3)
                .num_threads,
            5);
}

}  // namespace
}  // namespace colmap

namespace colmap {
namespace {

TEST(CommunityMapperSummary, TextHasTheFiguresScriptsRead) {
  CommunityMapperSummary summary;
  summary.num_view_graph_images = 128;
  summary.max_modularity = 0.5234;
  summary.community_sizes = {59, 39, 30};
  summary.reused_communities = {0, 2};
  summary.reconstructed_communities = {1};
  summary.extra_community_origins = {0};
  summary.model_num_registered = {127};
  summary.phase_seconds = {{"Partition", 0.25},
                           {"Final bundle adjustment", 12.5}};
  summary.peak_memory_mb = 233.4;
  const std::string text = CommunityMapperSummaryToText(summary);
  for (const std::string line :
       {"num_view_graph_images 128\n",
        "max_modularity 0.5234\n",
        "num_communities 3\n",
        "community_sizes 59 39 30\n",
        "extra_community_origins 0\n",
        "reused_communities 0 2\n",
        "reconstructed_communities 1\n",
        "model_num_registered 127\n",
        "phase_seconds partition 0.250\n",
        "phase_seconds final_bundle_adjustment 12.500\n",
        "peak_memory_mb 233.4\n"}) {
    EXPECT_NE(text.find(line), std::string::npos) << line << text;
  }
}

}  // namespace
}  // namespace colmap
