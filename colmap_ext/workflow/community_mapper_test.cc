#include "colmap_ext/workflow/community_mapper.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

// The incremental mapper's own global adjustment schedule (COLMAP's
// defaults).
void ExpectMappersGlobalAdjustments(const IncrementalPipelineOptions& options) {
  const IncrementalPipelineOptions defaults;
  EXPECT_EQ(options.ba_global_function_tolerance,
            defaults.ba_global_function_tolerance);
  EXPECT_EQ(options.ba_global_frames_ratio, defaults.ba_global_frames_ratio);
  EXPECT_EQ(options.ba_global_points_ratio, defaults.ba_global_points_ratio);
}

TEST(CommunityIncrementalOptions, CommunitySettingsOverrideTheMappers) {
  CommunityMapperController::Options options;
  options.community_ba_function_tolerance = 1e-5;
  options.community_ba_global_ratio = 1.3;
  options.incremental_options.mapper.ba_local_num_images = 9;
  const IncrementalPipelineOptions community_options =
      options.CommunityIncrementalOptions({"a.jpg", "b.jpg"},
                                          /*num_threads=*/3);
  EXPECT_EQ(community_options.image_names,
            std::vector<std::string>({"a.jpg", "b.jpg"}));
  EXPECT_EQ(community_options.num_threads, 3);
  EXPECT_EQ(community_options.ba_global_function_tolerance, 1e-5);
  EXPECT_EQ(community_options.ba_global_frames_ratio, 1.3);
  EXPECT_EQ(community_options.ba_global_points_ratio, 1.3);
  // Everything else is the mapper's.
  EXPECT_EQ(community_options.mapper.ba_local_num_images, 9);
  EXPECT_TRUE(community_options.Check());
}

TEST(CommunityIncrementalOptions, MinusOneKeepsTheMappersSettings) {
  CommunityMapperController::Options options;
  options.community_ba_function_tolerance = -1;
  options.community_ba_global_ratio = -1;
  options.incremental_options.num_threads = 5;
  const IncrementalPipelineOptions community_options =
      options.CommunityIncrementalOptions({"a.jpg"}, /*num_threads=*/3);
  EXPECT_EQ(community_options.num_threads, 5);
  ExpectMappersGlobalAdjustments(community_options);
}

// The mapper's own schedule, where asked for, whatever the community
// settings.
TEST(CommunityIncrementalOptions, MapperScheduleKeepsTheMappers) {
  CommunityMapperController::Options options;
  options.community_ba_function_tolerance = 1e-5;
  options.community_ba_global_ratio = 1.3;
  const IncrementalPipelineOptions community_options =
      options.CommunityIncrementalOptions(
          {"a.jpg"}, /*num_threads=*/3, /*mapper_schedule=*/true);
  EXPECT_EQ(community_options.num_threads, 3);
  EXPECT_EQ(community_options.image_names, std::vector<std::string>({"a.jpg"}));
  ExpectMappersGlobalAdjustments(community_options);
}

// The plan's only community is the result (nothing is merged and adjusted
// after it): the mapper's schedule, whatever its cameras.
TEST(CommunityMapperOptions, TheOnlyCommunityUsesTheMappersSchedule) {
  CommunityMapperController::Options options;
  options.mapper_schedule_for_own_cameras = false;
  EXPECT_TRUE(options.UsesMapperSchedule(/*own_camera_fraction=*/0,
                                         /*only_community=*/true));
  EXPECT_FALSE(options.UsesMapperSchedule(/*own_camera_fraction=*/0,
                                          /*only_community=*/false));
}

TEST(CommunityMapperOptions, ImagesWithCamerasOfTheirOwnUseTheMappersSchedule) {
  CommunityMapperController::Options options;
  // Most images with a camera of their own: the mapper's schedule.
  EXPECT_TRUE(options.UsesMapperSchedule(/*own_camera_fraction=*/0.9));
  // Half or fewer: the community settings.
  EXPECT_FALSE(options.UsesMapperSchedule(/*own_camera_fraction=*/0.5));
  // Turned off: the community settings whatever the cameras.
  options.mapper_schedule_for_own_cameras = false;
  EXPECT_FALSE(options.UsesMapperSchedule(/*own_camera_fraction=*/1.0));
}

// With both community settings at -1 there is nothing to try again.
TEST(CommunityMapperOptions, MinusOneLeavesNoCommunitySchedule) {
  CommunityMapperController::Options options;
  EXPECT_TRUE(options.HasCommunitySchedule());
  options.community_ba_function_tolerance = -1;
  EXPECT_TRUE(options.HasCommunitySchedule());
  options.community_ba_global_ratio = -1;
  EXPECT_FALSE(options.HasCommunitySchedule());
}

TEST(CommunityMapperOptions, CheckRefusesARatioOfOneOrLess) {
  CommunityMapperController::Options options;
  EXPECT_TRUE(options.Check());
  options.community_ba_global_ratio = 1.0;
  EXPECT_FALSE(options.Check());
  options.community_ba_global_ratio = -1;
  EXPECT_TRUE(options.Check());
}

}  // namespace
}  // namespace colmap

namespace colmap {
namespace {

TEST(CommunityMapperSummary, TextHasTheFiguresScriptsRead) {
  CommunityMapperController::Summary summary;
  summary.num_view_graph_images = 128;
  summary.max_modularity = 0.5234;
  summary.community_sizes = {59, 39, 30};
  summary.reused_communities = {0, 2};
  summary.reconstructed_communities = {1};
  summary.community_excluded = {false, true, false, false};
  summary.extra_community_origins = {0};
  summary.model_num_registered = {127};
  summary.phase_seconds = {{"Partition", 0.25},
                           {"Final bundle adjustment", 12.5}};
  summary.peak_memory_mb = 233.4;
  const std::string text = CommunityMapperController::SummaryToText(summary);
  for (const std::string line :
       {"num_view_graph_images 128\n",
        "max_modularity 0.5234\n",
        "num_communities 3\n",
        "community_sizes 59 39 30\n",
        "extra_community_origins 0\n",
        "reused_communities 0 2\n",
        "reconstructed_communities 1\n",
        "num_excluded_communities 1\n",
        "model_num_registered 127\n",
        "phase_seconds partition 0.250\n",
        "phase_seconds final_bundle_adjustment 12.500\n",
        "peak_memory_mb 233.4\n"}) {
    EXPECT_NE(text.find(line), std::string::npos) << line << text;
  }
}

}  // namespace
}  // namespace colmap
