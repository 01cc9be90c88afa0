#include "colmap_ext/workflow/community_io.h"

#include "colmap_ext/workflow/atomic_output.h"
#include "colmap_ext/testing/testing.h"

#include "colmap/util/ply.h"

#include <filesystem>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(CommunitiesToText, ListsEveryImageOnceWithItsCommunity) {
  // Two triangles joined by one edge; images named out of order.
  const std::vector<std::pair<image_t, image_t>> pairs = {
      {1, 2}, {2, 3}, {1, 3}, {4, 5}, {5, 6}, {4, 6}, {3, 4}};
  const std::unordered_map<image_t, std::string> names = {{1, "f.jpg"},
                                                          {2, "e.jpg"},
                                                          {3, "d.jpg"},
                                                          {4, "c.jpg"},
                                                          {5, "b.jpg"},
                                                          {6, "a.jpg"}};
  const ViewGraph view_graph =
      ViewGraph::Create(pairs, std::vector<int>(pairs.size(), 100), 15, names);
  CommunityDetectionOptions options;
  options.min_community_size = 2;
  const CommunityPartition partition =
      DetectCommunities(view_graph.ToWeightedGraph(ViewGraphEdgeWeight::kUnit),
                        GreedyModularityPartitioner(),
                        options);
  ASSERT_EQ(partition.NumCommunities(), 2);

  const std::string text =
      CommunitiesToText(view_graph, partition, 0.3, ViewGraphEdgeWeight::kUnit);
  EXPECT_NE(text.find("# View graph: 6 images, 7 edges (unit weights)"),
            std::string::npos)
      << text;
  EXPECT_NE(
      text.find("Qmax 0.3571, 2 parts (largest conductance 0.143), split"),
      std::string::npos)
      << text;
  EXPECT_NE(text.find("# 2 communities"), std::string::npos) << text;
  // Sorted by name.
  EXPECT_LT(text.find("a.jpg"), text.find("b.jpg"));
  EXPECT_LT(text.find("e.jpg"), text.find("f.jpg"));

  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "communities.txt").string();
  WriteTextFileAtomically(text, path);
  const std::unordered_map<std::string, int> communities =
      ReadCommunities(path);
  ASSERT_EQ(communities.size(), 6);
  EXPECT_EQ(communities.at("f.jpg"), communities.at("d.jpg"));
  EXPECT_EQ(communities.at("a.jpg"), communities.at("c.jpg"));
  EXPECT_NE(communities.at("a.jpg"), communities.at("f.jpg"));
}

TEST(ReadCommunities, RejectsAnImageListedTwice) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "communities.txt").string();
  WriteTextFileAtomically("# header\na.jpg 0\nb.jpg 1\na.jpg 1\n", path);
  EXPECT_THROW(ReadCommunities(path), std::exception);
}

TEST(ReadImageList, DistinctTrimmedNamesOrAProblem) {
  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "images.txt").string();
  std::vector<std::string> names;
  EXPECT_NE(ReadImageList(path, &names).find("does not exist"),
            std::string::npos);
  WriteTextFileAtomically(" \n\n", path);
  EXPECT_NE(ReadImageList(path, &names).find("names no image"),
            std::string::npos);
  EXPECT_TRUE(names.empty());
  WriteTextFileAtomically("b.jpg\n  dir/a b.jpg \n\nb.jpg\n", path);
  EXPECT_EQ(ReadImageList(path, &names), "");
  EXPECT_EQ(names, (std::vector<std::string>{"b.jpg", "dir/a b.jpg"}));
}

TEST(CommunityCamerasToPly, ColmapReadsTheColouredCameras) {
  Reconstruction reconstruction;
  reconstruction.AddCameraWithTrivialRig(
      Camera::CreateFromModelName(1, "PINHOLE", 100, 100, 100));
  std::unordered_map<image_t, int> community_of_image;
  for (image_t image_id = 1; image_id <= 4; ++image_id) {
    Image image;
    image.SetImageId(image_id);
    image.SetCameraId(1);
    image.SetName(std::to_string(image_id));
    reconstruction.AddImageWithTrivialFrame(
        image,
        Rigid3d(Eigen::Quaterniond::Identity(),
                Eigen::Vector3d(-1.0 * image_id, 0, 0)));
    if (image_id != 4) {
      community_of_image[image_id] = image_id <= 2 ? 0 : 1;
    }
  }

  const std::string path =
      (std::filesystem::path(CreateTestFolder()) / "communities.ply").string();
  WriteTextFileAtomically(
      CommunityCamerasToPly(reconstruction, community_of_image), path);
  // COLMAP's reader, which its GUI's "Import model from..." uses.
  const std::vector<PlyPoint> points = ReadPly(path);
  ASSERT_EQ(points.size(), 4);
  EXPECT_FLOAT_EQ(points[0].x, 1.0f);
  EXPECT_FLOAT_EQ(points[3].x, 4.0f);
  const Eigen::Vector3ub color0 = CommunityColor(0);
  const Eigen::Vector3ub color1 = CommunityColor(1);
  EXPECT_EQ(points[0].r, color0(0));
  EXPECT_EQ(points[1].g, color0(1));
  EXPECT_EQ(points[2].b, color1(2));
  EXPECT_NE(color0, color1);
  // Without a community: grey.
  EXPECT_EQ(points[3].r, 160);
  EXPECT_EQ(points[3].g, 160);
}

TEST(CommunityColor, DistinctForManyCommunities) {
  std::set<std::tuple<int, int, int>> colors;
  for (int c = 0; c < 30; ++c) {
    const Eigen::Vector3ub color = CommunityColor(c);
    colors.emplace(color(0), color(1), color(2));
  }
  EXPECT_EQ(colors.size(), 30);
}

}  // namespace
}  // namespace colmap
