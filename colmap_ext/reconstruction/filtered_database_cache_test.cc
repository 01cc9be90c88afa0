#include "colmap_ext/reconstruction/filtered_database_cache.h"

#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <unordered_set>
#include <vector>

#include <gtest/gtest.h>

namespace colmap {
namespace {

// A generated scene of two landmarks joined by a walkway, in a database.
std::shared_ptr<Database> SceneDatabase(const unsigned int seed) {
  SyntheticSceneOptions options;
  options.num_clusters = 2;
  options.num_images_per_cluster = 10;
  options.num_images_per_link = 6;
  options.num_points_per_cluster = 600;
  options.num_points_per_link = 300;
  options.seed = seed;
  std::shared_ptr<Database> database =
      Database::Open(std::filesystem::path(CreateTestFolder()) / "database.db");
  SyntheticScene scene;
  SynthesizeCommunityScene(options, &scene, database.get());
  return database;
}

DatabaseCache::Options CacheOptions(const size_t min_num_matches) {
  DatabaseCache::Options options;
  options.min_num_matches = min_num_matches;
  return options;
}

std::vector<image_pair_t> SortedImagePairs(const DatabaseCache& cache) {
  std::vector<image_pair_t> pair_ids =
      cache.CorrespondenceGraph()->ImagePairs();
  std::sort(pair_ids.begin(), pair_ids.end());
  return pair_ids;
}

// The same images, frames and cameras, and the same correspondences between
// the images of every pair of `expected`, in the same order.
void ExpectSameCache(const DatabaseCache& expected,
                     const DatabaseCache& found) {
  ASSERT_EQ(found.NumImages(), expected.NumImages());
  for (const auto& [image_id, image] : expected.Images()) {
    ASSERT_TRUE(found.ExistsImage(image_id)) << image.Name();
    EXPECT_EQ(found.Image(image_id).Name(), image.Name());
    EXPECT_EQ(found.Image(image_id).FrameId(), image.FrameId());
    EXPECT_EQ(found.Image(image_id).Points2D(), image.Points2D());
  }
  EXPECT_EQ(found.NumFrames(), expected.NumFrames());
  for (const auto& [frame_id, frame] : expected.Frames()) {
    ASSERT_TRUE(found.ExistsFrame(frame_id));
    EXPECT_EQ(found.Frame(frame_id).DataIds(), frame.DataIds());
    EXPECT_EQ(found.Frame(frame_id).RigId(), frame.RigId());
  }
  EXPECT_EQ(found.NumCameras(), expected.NumCameras());
  EXPECT_EQ(found.NumRigs(), expected.NumRigs());

  const CorrespondenceGraph& expected_graph = *expected.CorrespondenceGraph();
  const CorrespondenceGraph& found_graph = *found.CorrespondenceGraph();
  ASSERT_EQ(SortedImagePairs(found), SortedImagePairs(expected));
  FeatureMatches expected_matches;
  FeatureMatches found_matches;
  for (const image_pair_t pair_id : SortedImagePairs(expected)) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    expected_graph.ExtractMatchesBetweenImages(
        image_id1, image_id2, expected_matches);
    found_graph.ExtractMatchesBetweenImages(
        image_id1, image_id2, found_matches);
    ASSERT_EQ(found_matches.size(), expected_matches.size());
    for (size_t i = 0; i < found_matches.size(); ++i) {
      EXPECT_EQ(found_matches[i].point2D_idx1,
                expected_matches[i].point2D_idx1);
      EXPECT_EQ(found_matches[i].point2D_idx2,
                expected_matches[i].point2D_idx2);
    }
    EXPECT_EQ(
        found_graph.ExtractTwoViewGeometry(image_id1, image_id2, false).config,
        expected_graph.ExtractTwoViewGeometry(image_id1, image_id2, false)
            .config);
  }
}

TEST(CreateFilteredDatabaseCache, WithoutAFilterAsDatabaseCacheCreate) {
  const std::shared_ptr<Database> database = SceneDatabase(/*seed=*/4);
  for (const size_t min_num_matches : {1, 15, 60}) {
    const DatabaseCache::Options options = CacheOptions(min_num_matches);
    const auto expected = DatabaseCache::Create(*database, options);
    const auto found = CreateFilteredDatabaseCache(*database, options);
    ASSERT_GT(expected->NumImages(), 0);
    ExpectSameCache(*expected, *found);
  }
}

// The filter leaves out exactly the pairs it refuses; the others keep all
// their matches.
TEST(CreateFilteredDatabaseCache, LeavesOutExactlyThePairsRefused) {
  const std::shared_ptr<Database> database = SceneDatabase(/*seed=*/5);
  const DatabaseCache::Options options = CacheOptions(/*min_num_matches=*/1);
  const auto whole = DatabaseCache::Create(*database, options);
  const std::vector<image_pair_t> pair_ids = SortedImagePairs(*whole);
  ASSERT_GE(pair_ids.size(), 10);
  // Refuse every third pair.
  std::set<image_pair_t> refused;
  for (size_t i = 0; i < pair_ids.size(); i += 3) {
    refused.insert(pair_ids[i]);
  }
  std::set<image_pair_t> asked;
  const auto filtered = CreateFilteredDatabaseCache(
      *database,
      options,
      [&](const image_t image_id1, const image_t image_id2) {
        const image_pair_t pair_id = ImagePairToPairId(image_id1, image_id2);
        EXPECT_EQ(PairIdToImagePair(pair_id),
                  std::make_pair(image_id1, image_id2));
        asked.insert(pair_id);
        return refused.count(pair_id) == 0;
      });
  EXPECT_EQ(asked, std::set<image_pair_t>(pair_ids.begin(), pair_ids.end()));

  const CorrespondenceGraph& graph = *filtered->CorrespondenceGraph();
  const CorrespondenceGraph& whole_graph = *whole->CorrespondenceGraph();
  FeatureMatches expected;
  FeatureMatches found;
  for (const image_pair_t pair_id : pair_ids) {
    const auto [image_id1, image_id2] = PairIdToImagePair(pair_id);
    if (refused.count(pair_id) > 0) {
      EXPECT_EQ(graph.NumMatchesBetweenImages(image_id1, image_id2), 0);
      continue;
    }
    whole_graph.ExtractMatchesBetweenImages(image_id1, image_id2, expected);
    graph.ExtractMatchesBetweenImages(image_id1, image_id2, found);
    ASSERT_EQ(found.size(), expected.size());
    for (size_t i = 0; i < found.size(); ++i) {
      EXPECT_EQ(found[i].point2D_idx1, expected[i].point2D_idx1);
      EXPECT_EQ(found[i].point2D_idx2, expected[i].point2D_idx2);
    }
  }
  EXPECT_EQ(graph.NumImagePairs(), pair_ids.size() - refused.size());

  // Refusing every pair of an image leaves the image out.
  const image_t lonely_image_id = whole->Images().begin()->first;
  const auto without_image = CreateFilteredDatabaseCache(
      *database,
      options,
      [&](const image_t image_id1, const image_t image_id2) {
        return image_id1 != lonely_image_id && image_id2 != lonely_image_id;
      });
  EXPECT_FALSE(without_image->ExistsImage(lonely_image_id));
  EXPECT_LT(without_image->NumImages(), whole->NumImages());
}

// A subset of the images reads only the pairs among them, and gets what
// DatabaseCache::Create gives for it.
TEST(CreateFilteredDatabaseCache, ImageSubsetAsDatabaseCacheCreate) {
  const std::shared_ptr<Database> database = SceneDatabase(/*seed=*/6);
  DatabaseCache::Options options = CacheOptions(/*min_num_matches=*/15);
  for (const Image& image : database->ReadAllImages()) {
    if (image.ImageId() % 2 == 0) {
      options.image_names.insert(image.Name());
    }
  }
  const auto expected = DatabaseCache::Create(*database, options);
  const auto found = CreateFilteredDatabaseCache(*database, options);
  ExpectSameCache(*expected, *found);
  ASSERT_GT(found->CorrespondenceGraph()->NumImagePairs(), 5);
  for (const auto& [image_id, image] : found->Images()) {
    EXPECT_EQ(options.image_names.count(image.Name()), 1);
  }
  EXPECT_LT(found->NumImages(),
            DatabaseCache::Create(*database, CacheOptions(15))->NumImages());
}

// With `ignore_watermarks`, a pair the database marks as a watermark is left
// out, as DatabaseCache::Create leaves it out.
TEST(CreateFilteredDatabaseCache, IgnoresWatermarksAsDatabaseCacheCreate) {
  const std::shared_ptr<Database> database = SceneDatabase(/*seed=*/7);
  const std::vector<image_pair_t> pair_ids =
      SortedImagePairs(*DatabaseCache::Create(*database, CacheOptions(15)));
  ASSERT_GE(pair_ids.size(), 2);
  const auto [image_id1, image_id2] = PairIdToImagePair(pair_ids[1]);
  TwoViewGeometry watermark =
      database->ReadTwoViewGeometry(image_id1, image_id2);
  watermark.config = TwoViewGeometry::WATERMARK;
  database->UpdateTwoViewGeometry(image_id1, image_id2, watermark);

  for (const bool ignore_watermarks : {false, true}) {
    DatabaseCache::Options options = CacheOptions(15);
    options.ignore_watermarks = ignore_watermarks;
    const auto expected = DatabaseCache::Create(*database, options);
    const auto found = CreateFilteredDatabaseCache(*database, options);
    ExpectSameCache(*expected, *found);
    EXPECT_EQ(found->CorrespondenceGraph()->NumMatchesBetweenImages(
                  image_id1, image_id2) > 0,
              !ignore_watermarks);
  }
}

}  // namespace
}  // namespace colmap
