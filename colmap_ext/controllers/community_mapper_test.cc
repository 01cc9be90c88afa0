#include "colmap_ext/controllers/community_mapper.h"

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(CommunityIncrementalOptions, CommunitySettingsOverrideTheMappers) {
  CommunityMapperController::Options options;
  options.community_ba_function_tolerance = 1e-5;
  options.community_ba_global_ratio = 1.3;
  options.incremental_options.ba_local_num_images = 9;
  const IncrementalMapperOptions community_options =
      options.CommunityIncrementalOptions({"a.jpg", "b.jpg"},
                                          /*num_threads=*/3);
  EXPECT_EQ(community_options.image_names,
            std::unordered_set<std::string>({"a.jpg", "b.jpg"}));
  EXPECT_EQ(community_options.num_threads, 3);
  EXPECT_EQ(community_options.ba_global_function_tolerance, 1e-5);
  EXPECT_EQ(community_options.ba_global_images_ratio, 1.3);
  EXPECT_EQ(community_options.ba_global_points_ratio, 1.3);
  // Everything else is the mapper's.
  EXPECT_EQ(community_options.ba_local_num_images, 9);
  EXPECT_TRUE(community_options.Check());
}

TEST(CommunityIncrementalOptions, MinusOneKeepsTheMappersSettings) {
  CommunityMapperController::Options options;
  options.community_ba_function_tolerance = -1;
  options.community_ba_global_ratio = -1;
  options.incremental_options.num_threads = 5;
  const IncrementalMapperOptions defaults;
  const IncrementalMapperOptions community_options =
      options.CommunityIncrementalOptions({"a.jpg"}, /*num_threads=*/3);
  EXPECT_EQ(community_options.num_threads, 5);
  EXPECT_EQ(community_options.ba_global_function_tolerance,
            defaults.ba_global_function_tolerance);
  EXPECT_EQ(community_options.ba_global_images_ratio,
            defaults.ba_global_images_ratio);
  EXPECT_EQ(community_options.ba_global_points_ratio,
            defaults.ba_global_points_ratio);
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
