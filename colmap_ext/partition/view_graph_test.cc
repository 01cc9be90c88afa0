#include "colmap_ext/partition/view_graph.h"

#include "colmap_ext/testing/testing.h"

#include "colmap/scene/database.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace colmap {
namespace {

TEST(ViewGraph, CreateKeepsPairsWithEnoughInliers) {
  const std::vector<std::pair<image_t, image_t>> pairs = {
      {1, 2}, {2, 3}, {3, 4}, {7, 5}, {2, 1}, {4, 4}};
  const std::vector<int> num_inliers = {100, 14, 15, 30, 120, 50};
  const ViewGraph graph = ViewGraph::Create(
      pairs, num_inliers, /*min_num_matches=*/15, {{1, "a.jpg"}});

  // Image 2-3 is below the threshold, 4-4 is no pair, and 1-2 appears twice.
  EXPECT_EQ(graph.ImageIds(), (std::vector<image_t>{1, 2, 3, 4, 5, 7}));
  ASSERT_EQ(graph.NumEdges(), 3);
  EXPECT_EQ(graph.ImageNames()[0], "a.jpg");
  EXPECT_EQ(graph.ImageNames()[1], "image2");

  const ViewGraph::Edge& edge12 = graph.Edges()[0];
  EXPECT_EQ(graph.ImageIds()[edge12.vertex1], 1);
  EXPECT_EQ(graph.ImageIds()[edge12.vertex2], 2);
  EXPECT_EQ(edge12.num_inliers, 120);

  const WeightedGraph unit = graph.ToWeightedGraph(ViewGraphEdgeWeight::kUnit);
  const WeightedGraph weighted =
      graph.ToWeightedGraph(ViewGraphEdgeWeight::kNumInliers);
  EXPECT_EQ(unit.num_vertices, 6);
  EXPECT_EQ(unit.edges[0].weight, 1.0);
  EXPECT_EQ(weighted.edges[0].weight, 120.0);

  // {1, 2}, {3, 4} and {5, 7}.
  const auto components = unit.ConnectedComponents();
  ASSERT_EQ(components.size(), 3);
  EXPECT_EQ(components[0], (std::vector<int>{0, 1}));
  EXPECT_EQ(components[1], (std::vector<int>{2, 3}));
  EXPECT_EQ(components[2], (std::vector<int>{4, 5}));
}

TEST(WeightedGraph, InducedSubgraph) {
  WeightedGraph graph;
  graph.num_vertices = 4;
  graph.edges = {{0, 1, 1.0}, {1, 2, 2.0}, {2, 3, 3.0}, {3, 0, 4.0}};
  const WeightedGraph subgraph = graph.InducedSubgraph({3, 2, 1});
  EXPECT_EQ(subgraph.num_vertices, 3);
  ASSERT_EQ(subgraph.edges.size(), 2);
  EXPECT_EQ(subgraph.edges[0].vertex1, 2);
  EXPECT_EQ(subgraph.edges[0].vertex2, 1);
  EXPECT_EQ(subgraph.edges[0].weight, 2.0);
  EXPECT_EQ(subgraph.edges[1].weight, 3.0);
}

TEST(ViewGraph, ReadFromDatabase) {
  const std::shared_ptr<Database> database = Database::Open(
      std::filesystem::path(CreateTestFolder()) / "database.db");
  Camera camera = Camera::CreateFromModelName(
      kInvalidCameraId, "SIMPLE_PINHOLE", 100, 100, 100);
  const camera_t camera_id = database->WriteCamera(camera);
  std::vector<image_t> image_ids;
  for (int i = 0; i < 4; ++i) {
    Image image;
    image.SetName("image" + std::to_string(i) + ".png");
    image.SetCameraId(camera_id);
    image_ids.push_back(database->WriteImage(image));
  }
  auto write_pair = [&](int i, int j, int num_inliers) {
    TwoViewGeometry two_view_geometry;
    two_view_geometry.config = TwoViewGeometry::CALIBRATED;
    for (int k = 0; k < num_inliers; ++k) {
      two_view_geometry.inlier_matches.emplace_back(k, k);
    }
    database->WriteTwoViewGeometry(
        image_ids[i], image_ids[j], two_view_geometry);
  };
  write_pair(0, 1, 40);
  write_pair(1, 2, 10);
  write_pair(2, 3, 0);

  const ViewGraph graph = ViewGraph::Read(*database, /*min_num_matches=*/15);
  ASSERT_EQ(graph.NumVertices(), 2);
  ASSERT_EQ(graph.NumEdges(), 1);
  EXPECT_EQ(graph.ImageNames()[0], "image0.png");
  EXPECT_EQ(graph.ImageNames()[1], "image1.png");
  EXPECT_EQ(graph.Edges()[0].num_inliers, 40);
  // Images 2 and 3 were compared and had no inlier.
  EXPECT_EQ(graph.NumFailedPairs(), 1);
  write_pair(0, 3, 0);
  EXPECT_EQ(ViewGraph::Read(*database, 15).NumFailedPairs(), 2);
  EXPECT_EQ(ViewGraph::Create({{image_ids[0], image_ids[1]}}, {40}, 15)
                .NumFailedPairs(),
            0);

  const ViewGraph loose = ViewGraph::Read(*database, /*min_num_matches=*/5);
  EXPECT_EQ(loose.NumVertices(), 3);
  EXPECT_EQ(loose.NumEdges(), 2);

  // With a list, only the pairs of two listed images (0-1 is not one).
  const ViewGraph listed = ViewGraph::Read(
      *database, /*min_num_matches=*/5, {"image1.png", "image2.png"});
  ASSERT_EQ(listed.NumVertices(), 2);
  ASSERT_EQ(listed.NumEdges(), 1);
  EXPECT_EQ(listed.ImageNames()[0], "image1.png");
  EXPECT_EQ(listed.ImageNames()[1], "image2.png");
  EXPECT_EQ(listed.Edges()[0].num_inliers, 10);
}

TEST(ViewGraph, FramesAreOneVertexOfThePartition) {
  // Images 1 and 2 are one snapshot of a two-camera rig, 3 and 4 another;
  // image 5 has a frame of its own.
  const ViewGraph view_graph = [] {
    ViewGraph graph = ViewGraph::Create(
        {{1, 2}, {1, 3}, {2, 4}, {2, 3}, {4, 5}}, {50, 20, 30, 10, 40}, 15);
    graph.SetFrames({{1, 7}, {2, 7}, {3, 8}, {4, 8}, {5, 9}});
    return graph;
  }();
  EXPECT_EQ(view_graph.FrameVertices(),
            (std::vector<std::vector<int>>{{0, 1}, {2, 3}, {4}}));
  const WeightedGraph graph =
      view_graph.ToFrameGraph(ViewGraphEdgeWeight::kNumInliers);
  EXPECT_EQ(graph.num_vertices, 3);
  // The edge inside frame 7 is gone; those between frames 7 and 8 add up
  // (2-3, with fewer than 15 inliers, is no edge).
  ASSERT_EQ(graph.edges.size(), 2);
  EXPECT_EQ(graph.edges[0].vertex1, 0);
  EXPECT_EQ(graph.edges[0].vertex2, 1);
  EXPECT_EQ(graph.edges[0].weight, 20 + 30);
  EXPECT_EQ(graph.edges[1].vertex1, 1);
  EXPECT_EQ(graph.edges[1].vertex2, 2);
  EXPECT_EQ(graph.edges[1].weight, 40);
}

TEST(ViewGraph, WithoutRigsTheFrameGraphIsTheImageGraph) {
  const ViewGraph view_graph =
      ViewGraph::Create({{1, 2}, {2, 3}}, {50, 20}, 15);
  EXPECT_EQ(view_graph.FrameVertices(),
            (std::vector<std::vector<int>>{{0}, {1}, {2}}));
  const WeightedGraph frame_graph =
      view_graph.ToFrameGraph(ViewGraphEdgeWeight::kUnit);
  const WeightedGraph image_graph =
      view_graph.ToWeightedGraph(ViewGraphEdgeWeight::kUnit);
  ASSERT_EQ(frame_graph.edges.size(), image_graph.edges.size());
  for (size_t e = 0; e < image_graph.edges.size(); ++e) {
    EXPECT_EQ(frame_graph.edges[e].vertex1, image_graph.edges[e].vertex1);
    EXPECT_EQ(frame_graph.edges[e].vertex2, image_graph.edges[e].vertex2);
  }
}

TEST(ViewGraphEdgeWeight, FromString) {
  EXPECT_EQ(ViewGraphEdgeWeightFromString("unit"), ViewGraphEdgeWeight::kUnit);
  EXPECT_EQ(ViewGraphEdgeWeightFromString("num_inliers"),
            ViewGraphEdgeWeight::kNumInliers);
  EXPECT_THROW(ViewGraphEdgeWeightFromString("inliers"), std::exception);
}

}  // namespace
}  // namespace colmap
