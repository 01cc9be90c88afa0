#include "colmap_ext/partition/community_detection.h"

#include "colmap_ext/testing/synthetic_scene.h"
#include "colmap_ext/testing/testing.h"

#include <filesystem>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <igraph.h>

namespace colmap {
namespace {

// Modularity Q of the given membership on the given graph (edge weights are
// used), as defined at the top of community_detection.h.
double ComputeModularity(const WeightedGraph& graph,
                         const std::vector<int>& membership) {
  THROW_CHECK_EQ(membership.size(), static_cast<size_t>(graph.num_vertices));
  std::vector<double> degree(graph.num_vertices, 0.0);
  double total_weight = 0.0;  // m
  double intra_weight = 0.0;  // sum of weights of edges inside communities
  for (const auto& edge : graph.edges) {
    degree[edge.vertex1] += edge.weight;
    degree[edge.vertex2] += edge.weight;
    total_weight += edge.weight;
    if (membership[edge.vertex1] == membership[edge.vertex2]) {
      intra_weight += edge.weight;
    }
  }
  if (total_weight <= 0.0) {
    return 0.0;
  }
  std::map<int, double> community_degree;
  for (int vertex = 0; vertex < graph.num_vertices; ++vertex) {
    community_degree[membership[vertex]] += degree[vertex];
  }
  double expected = 0.0;
  for (const auto& label_and_degree : community_degree) {
    expected += label_and_degree.second * label_and_degree.second;
  }
  return intra_weight / total_weight -
         expected / (4.0 * total_weight * total_weight);
}

// Adds a clique on vertices [first, first + size).
void AddClique(const int first,
               const int size,
               const double weight,
               WeightedGraph* graph) {
  graph->num_vertices = std::max(graph->num_vertices, first + size);
  for (int i = first; i < first + size; ++i) {
    for (int j = first; j < i; ++j) {
      graph->edges.push_back({j, i, weight});
    }
  }
}

// Number of distinct communities among the given vertices.
int NumCommunitiesAmong(const CommunityPartition& partition,
                        const int first,
                        const int size) {
  std::set<int> labels;
  for (int i = first; i < first + size; ++i) {
    labels.insert(partition.membership[i]);
  }
  return static_cast<int>(labels.size());
}

// With the balance rule at one half.
CommunityDetectionOptions Options(const int min_community_size) {
  CommunityDetectionOptions options;
  options.min_community_size = min_community_size;
  options.max_community_fraction = 0.5;
  return options;
}

TEST(DetectCommunities, TwoCliquesJoinedByOneEdge) {
  WeightedGraph graph;
  AddClique(/*first=*/0, /*size=*/25, /*weight=*/1, &graph);
  AddClique(/*first=*/25, /*size=*/25, /*weight=*/1, &graph);
  graph.edges.push_back({3, 30, 1});

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), CommunityDetectionOptions());

  EXPECT_EQ(partition.NumCommunities(), 2);
  EXPECT_EQ(NumCommunitiesAmong(partition, 0, 25), 1);
  EXPECT_EQ(NumCommunitiesAmong(partition, 25, 25), 1);
  EXPECT_NE(partition.membership[0], partition.membership[25]);
  EXPECT_EQ(partition.num_components, 1);
  ASSERT_FALSE(partition.splits.empty());
  EXPECT_TRUE(partition.splits[0].accepted);
  EXPECT_GT(partition.splits[0].modularity, 0.45);
}

TEST(DetectCommunities, RingOfFourDenseClusters) {
  WeightedGraph graph;
  const int kClusterSize = 30;
  for (int c = 0; c < 4; ++c) {
    AddClique(c * kClusterSize, kClusterSize, 1, &graph);
  }
  // Each cluster is joined to the next by two edges, closing a ring.
  for (int c = 0; c < 4; ++c) {
    const int next = (c + 1) % 4;
    graph.edges.push_back({c * kClusterSize, next * kClusterSize + 1, 1});
    graph.edges.push_back({c * kClusterSize + 2, next * kClusterSize + 3, 1});
  }

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), CommunityDetectionOptions());

  ASSERT_EQ(partition.NumCommunities(), 4);
  std::set<int> labels;
  for (int c = 0; c < 4; ++c) {
    EXPECT_EQ(NumCommunitiesAmong(partition, c * kClusterSize, kClusterSize),
              1);
    labels.insert(partition.membership[c * kClusterSize]);
  }
  EXPECT_EQ(labels.size(), 4);
}

TEST(DetectCommunities, DenseRandomGraphStaysOneCommunity) {
  std::mt19937 rng(42);
  std::bernoulli_distribution has_edge(0.5);
  WeightedGraph graph;
  graph.num_vertices = 80;
  for (int i = 0; i < graph.num_vertices; ++i) {
    for (int j = 0; j < i; ++j) {
      if (has_edge(rng)) {
        graph.edges.push_back({j, i, 1});
      }
    }
  }

  // The paper's rule alone (the default): no structure, no split.
  CommunityDetectionOptions options;
  const CommunityPartition partition =
      DetectCommunities(graph, GreedyModularityPartitioner(), options);
  EXPECT_EQ(partition.NumCommunities(), 1);
  ASSERT_EQ(partition.splits.size(), 1);
  EXPECT_LT(partition.splits[0].modularity, 0.3);
  EXPECT_FALSE(partition.splits[0].accepted);

  // With the balance rule, a graph holding its whole component is cut at
  // its modularity peak all the same, into parts of at least
  // min_community_size, so that two workers share it.
  options.max_community_fraction = 0.5;
  const CommunityPartition balanced =
      DetectCommunities(graph, GreedyModularityPartitioner(), options);
  ASSERT_GE(balanced.splits.size(), 1);
  EXPECT_TRUE(balanced.splits[0].accepted);
  EXPECT_TRUE(balanced.splits[0].balance);
  ASSERT_GE(balanced.NumCommunities(), 2);
  for (const std::vector<int>& community : balanced.Communities()) {
    EXPECT_GE(community.size(), 20);
    EXPECT_LE(community.size(), 60);
  }
}

TEST(GreedyModularityPartitioner, ZacharyKarateClubQmax) {
  igraph_t karate;
  ASSERT_EQ(igraph_famous(&karate, "Zachary"), IGRAPH_SUCCESS);
  WeightedGraph graph;
  graph.num_vertices = static_cast<int>(igraph_vcount(&karate));
  for (igraph_integer_t e = 0; e < igraph_ecount(&karate); ++e) {
    graph.edges.push_back({static_cast<int>(IGRAPH_FROM(&karate, e)),
                           static_cast<int>(IGRAPH_TO(&karate, e)),
                           1.0});
  }
  igraph_destroy(&karate);
  ASSERT_EQ(graph.num_vertices, 34);
  ASSERT_EQ(graph.edges.size(), 78);

  const GraphPartitioner::Result result =
      GreedyModularityPartitioner().Partition(graph);

  // Clauset, Newman and Moore's greedy algorithm on the karate club peaks at
  // Q = 0.3807 with three communities.
  EXPECT_NEAR(result.modularity, 0.3807, 1e-4);
  EXPECT_EQ(result.num_communities, 3);
  EXPECT_NEAR(
      ComputeModularity(graph, result.membership), result.modularity, 1e-9);
}

TEST(DetectCommunities, SmallCommunityMergedIntoNeighbourWithMostCrossEdges) {
  // Cliques A (30), B (30) and a small clique S (6). S has 3 edges to B and
  // 1 edge to A, so it belongs to B after the merge.
  WeightedGraph graph;
  AddClique(/*first=*/0, /*size=*/30, 1, &graph);   // A
  AddClique(/*first=*/30, /*size=*/30, 1, &graph);  // B
  AddClique(/*first=*/60, /*size=*/6, 1, &graph);   // S
  graph.edges.push_back({0, 30, 1});
  graph.edges.push_back({60, 5, 1});
  graph.edges.push_back({61, 35, 1});
  graph.edges.push_back({62, 36, 1});
  graph.edges.push_back({63, 37, 1});

  const CommunityPartition unmerged = DetectCommunities(
      graph, GreedyModularityPartitioner(), Options(/*min_community_size=*/2));
  ASSERT_EQ(unmerged.NumCommunities(), 3);

  const CommunityPartition merged = DetectCommunities(
      graph, GreedyModularityPartitioner(), Options(/*min_community_size=*/20));
  EXPECT_EQ(merged.num_communities_before_merge, 3);
  ASSERT_EQ(merged.NumCommunities(), 2);
  EXPECT_EQ(NumCommunitiesAmong(merged, 30, 36), 1);
  EXPECT_NE(merged.membership[0], merged.membership[60]);
  // Largest community first.
  EXPECT_EQ(merged.membership[60], 0);
}

TEST(DetectCommunities, SmallCommunitiesMergeUntilOnlyOneIsLeft) {
  WeightedGraph graph;
  AddClique(/*first=*/0, /*size=*/10, 1, &graph);
  AddClique(/*first=*/10, /*size=*/10, 1, &graph);
  graph.edges.push_back({0, 10, 1});

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), Options(/*min_community_size=*/20));

  EXPECT_EQ(partition.num_communities_before_merge, 2);
  EXPECT_EQ(partition.NumCommunities(), 1);
}

TEST(DetectCommunities, ComponentsArePartitionedSeparately) {
  // Component 1: two cliques joined by an edge. Component 2: one clique,
  // smaller than the minimum size, which has nothing to merge into.
  WeightedGraph graph;
  AddClique(/*first=*/0, /*size=*/25, 1, &graph);
  AddClique(/*first=*/25, /*size=*/25, 1, &graph);
  graph.edges.push_back({0, 25, 1});
  AddClique(/*first=*/50, /*size=*/8, 1, &graph);

  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), CommunityDetectionOptions());

  EXPECT_EQ(partition.num_components, 2);
  ASSERT_EQ(partition.NumCommunities(), 3);
  EXPECT_EQ(NumCommunitiesAmong(partition, 0, 25), 1);
  EXPECT_EQ(NumCommunitiesAmong(partition, 25, 25), 1);
  EXPECT_EQ(NumCommunitiesAmong(partition, 50, 8), 1);
  EXPECT_EQ(partition.membership[50], 2);  // the smallest comes last
  // Both components were examined on their own.
  int num_top_level_splits = 0;
  for (const auto& split : partition.splits) {
    num_top_level_splits += split.depth == 0;
  }
  EXPECT_EQ(num_top_level_splits, 2);
}

TEST(DetectCommunities, WeightsRevealStructureThatUnitWeightsHide) {
  // A complete graph on 40 images, as exhaustive matching of a small scene
  // produces: every pair is verified, but pairs within each half have many
  // more inliers than pairs across the halves.
  std::vector<std::pair<image_t, image_t>> pairs;
  std::vector<int> num_inliers;
  for (image_t i = 1; i <= 40; ++i) {
    for (image_t j = 1; j < i; ++j) {
      pairs.emplace_back(j, i);
      num_inliers.push_back(((i <= 20) == (j <= 20)) ? 500 : 20);
    }
  }
  const ViewGraph view_graph =
      ViewGraph::Create(pairs, num_inliers, /*min_num_matches=*/15);
  ASSERT_EQ(view_graph.NumEdges(), 40 * 39 / 2);

  const CommunityPartition unit =
      DetectCommunities(view_graph.ToWeightedGraph(ViewGraphEdgeWeight::kUnit),
                        GreedyModularityPartitioner(),
                        Options(/*min_community_size=*/5));
  EXPECT_EQ(unit.NumCommunities(), 1);
  EXPECT_LT(unit.MaxModularity(), 0.3);

  const CommunityPartition weighted = DetectCommunities(
      view_graph.ToWeightedGraph(ViewGraphEdgeWeight::kNumInliers),
      GreedyModularityPartitioner(),
      Options(/*min_community_size=*/5));
  ASSERT_EQ(weighted.NumCommunities(), 2);
  EXPECT_GT(weighted.MaxModularity(), 0.3);
  for (int vertex = 0; vertex < 40; ++vertex) {
    const bool first_half = view_graph.ImageIds()[vertex] <= 20;
    EXPECT_EQ(weighted.membership[vertex] == weighted.membership[0],
              first_half);
  }
}

// Splits every graph of more than 8 vertices in two by vertex index, the
// first `fraction` of them (rounded up) and the rest, with a fixed
// modularity: exercises the recursion alone.
class FractionPartitioner : public GraphPartitioner {
 public:
  explicit FractionPartitioner(double modularity, double fraction = 0.5)
      : modularity_(modularity), fraction_(fraction) {}
  Result Partition(const WeightedGraph& graph) const override {
    Result result;
    result.membership.assign(graph.num_vertices, 0);
    if (graph.num_vertices <= 8) {
      result.num_communities = 1;
      return result;
    }
    for (int i = 0; i < graph.num_vertices; ++i) {
      result.membership[i] = i < fraction_ * graph.num_vertices ? 0 : 1;
    }
    result.num_communities = 2;
    result.modularity = modularity_;
    return result;
  }

 private:
  const double modularity_;
  const double fraction_;
};

WeightedGraph Path(const int num_vertices) {
  WeightedGraph graph;
  graph.num_vertices = num_vertices;
  for (int i = 1; i < num_vertices; ++i) {
    graph.edges.push_back({i - 1, i, 1});
  }
  return graph;
}

TEST(DetectCommunities, RecursesUntilNoCommunitySplits) {
  const CommunityPartition partition =
      DetectCommunities(Path(32),
                        FractionPartitioner(/*modularity=*/0.5),
                        Options(/*min_community_size=*/2));
  // 32 -> 16 -> 8: four communities of eight consecutive vertices.
  ASSERT_EQ(partition.NumCommunities(), 4);
  for (int c = 0; c < 4; ++c) {
    EXPECT_EQ(NumCommunitiesAmong(partition, 8 * c, 8), 1);
  }
  int max_depth = 0;
  for (const auto& split : partition.splits) {
    max_depth = std::max(max_depth, split.depth);
  }
  EXPECT_EQ(max_depth, 2);
}

TEST(DetectCommunities, CommunityHoldingMoreThanItsShareIsSplit) {
  // No modularity above the threshold anywhere: only the balance rule
  // splits, and only where a (sub)graph holds more than half its component
  // and two parts reach the minimum size.
  CommunityDetectionOptions options = Options(/*min_community_size=*/8);
  const CommunityPartition partition = DetectCommunities(
      Path(32), FractionPartitioner(/*modularity=*/0.1), options);
  EXPECT_EQ(partition.NumCommunities(), 2);
  EXPECT_EQ(NumCommunitiesAmong(partition, 0, 16), 1);
  EXPECT_EQ(NumCommunitiesAmong(partition, 16, 16), 1);
  ASSERT_EQ(partition.splits.size(), 3);
  EXPECT_TRUE(partition.splits[0].balance);
  EXPECT_FALSE(partition.splits[1].accepted);

  // Parts below the minimum size: no split.
  options.min_community_size = 17;
  EXPECT_EQ(DetectCommunities(
                Path(32), FractionPartitioner(/*modularity=*/0.1), options)
                .NumCommunities(),
            1);
  // The paper's rule alone.
  options = Options(/*min_community_size=*/8);
  options.max_community_fraction = 1;
  EXPECT_EQ(DetectCommunities(
                Path(32), FractionPartitioner(/*modularity=*/0.1), options)
                .NumCommunities(),
            1);
}

TEST(DetectCommunities, BalanceRuleCutsOnlyOnce) {
  // 40 images without structure: the balance rule cuts them 16 / 24. The
  // 24 still hold more than half the component, but their own peak says
  // they have no structure either: they stay one community.
  CommunityDetectionOptions options = Options(/*min_community_size=*/8);
  const CommunityPartition partition = DetectCommunities(
      Path(40),
      FractionPartitioner(/*modularity=*/0.1, /*fraction=*/0.4),
      options);
  EXPECT_EQ(partition.NumCommunities(), 2);
  EXPECT_EQ(NumCommunitiesAmong(partition, 0, 16), 1);
  EXPECT_EQ(NumCommunitiesAmong(partition, 16, 24), 1);
  ASSERT_EQ(partition.splits.size(), 3);
  EXPECT_TRUE(partition.splits[0].balance);
  EXPECT_FALSE(partition.splits[1].accepted);
  EXPECT_FALSE(partition.splits[2].accepted);

  // Above the threshold, the parts of a balance cut still split.
  options.modularity_threshold = 0.05;
  EXPECT_GT(DetectCommunities(
                Path(40),
                FractionPartitioner(/*modularity=*/0.1, /*fraction=*/0.4),
                options)
                .NumCommunities(),
            2);
}

TEST(DetectCommunities, ModularityAtThresholdDoesNotSplit) {
  CommunityDetectionOptions options = Options(/*min_community_size=*/2);
  options.modularity_threshold = 0.5;
  options.max_community_fraction = 1;
  const CommunityPartition partition = DetectCommunities(
      Path(32), FractionPartitioner(/*modularity=*/0.5), options);
  EXPECT_EQ(partition.NumCommunities(), 1);
}

TEST(DetectCommunities, IsolatedVerticesAndEmptyGraph) {
  WeightedGraph graph;
  graph.num_vertices = 3;
  const CommunityPartition partition = DetectCommunities(
      graph, GreedyModularityPartitioner(), CommunityDetectionOptions());
  EXPECT_EQ(partition.num_components, 3);
  EXPECT_EQ(partition.NumCommunities(), 3);
  EXPECT_TRUE(partition.splits.empty());

  const CommunityPartition empty =
      DetectCommunities(WeightedGraph(),
                        GreedyModularityPartitioner(),
                        CommunityDetectionOptions());
  EXPECT_EQ(empty.NumCommunities(), 0);
}

TEST(ExtendCommunities, BorrowsTheBestConnectedBorderImages) {
  // Cliques A = 0..9 and B = 10..19, joined by 9-10, 8-10, 7-10, 9-11,
  // 8-11 and a weak 6-12.
  WeightedGraph graph;
  AddClique(/*first=*/0, /*size=*/10, 1, &graph);
  AddClique(/*first=*/10, /*size=*/10, 1, &graph);
  for (const auto& edge : std::vector<std::pair<int, int>>{
           {9, 10}, {8, 10}, {7, 10}, {9, 11}, {8, 11}, {6, 12}}) {
    graph.edges.push_back({edge.first, edge.second, 1});
  }
  CommunityPartition partition;
  for (int vertex = 0; vertex < 20; ++vertex) {
    partition.membership.push_back(vertex < 10 ? 0 : 1);
  }

  // Without overlap, the communities are returned as they are.
  EXPECT_EQ(ExtendCommunities(graph, partition, /*num_overlap_images=*/0),
            partition.Communities());

  const std::vector<std::vector<int>> extended =
      ExtendCommunities(graph, partition, /*num_overlap_images=*/2);
  ASSERT_EQ(extended.size(), 2);
  // A's own images first, then 10 (three edges into A), then 11 (two into
  // A, one to 10), not the weakly linked 12.
  std::vector<int> expected_a = partition.Communities()[0];
  expected_a.push_back(10);
  expected_a.push_back(11);
  EXPECT_EQ(extended[0], expected_a);
  // B borrows 8 and 9 (two edges into B each, then one to each other), not
  // 6 or 7 (one edge into B).
  ASSERT_EQ(extended[1].size(), 12);
  EXPECT_EQ(std::set<int>(extended[1].begin() + 10, extended[1].end()),
            std::set<int>({8, 9}));

  // A community borrows at most what its neighbour has.
  const std::vector<std::vector<int>> all =
      ExtendCommunities(graph, partition, /*num_overlap_images=*/100);
  EXPECT_EQ(all[0].size(), 20);
  EXPECT_EQ(std::set<int>(all[0].begin(), all[0].end()).size(), 20);
}

// Three cliques of 10 in a row, the middle one joined to each end one by 30
// edges: Qmax is above 0.3, but the middle part has 40% of its edges to the
// others: it is not a community.
WeightedGraph ThreeCliquesInARow() {
  WeightedGraph graph;
  for (int first : {0, 10, 20}) {
    AddClique(first, /*size=*/10, /*weight=*/1, &graph);
  }
  for (int i = 0; i < 30; ++i) {
    graph.edges.push_back({i % 10, 10 + (i % 10 + i / 10) % 10, 1});
    graph.edges.push_back({20 + i % 10, 10 + (i % 10 + i / 10 + 5) % 10, 1});
  }
  return graph;
}

TEST(DetectCommunities, SplitWhosePartsAreNotCommunitiesIsRefused) {
  CommunityDetectionOptions options = Options(/*min_community_size=*/5);
  options.max_community_fraction = 1;  // no balance split
  options.max_part_conductance = 1;    // the threshold alone, as the paper
  const CommunityPartition paper = DetectCommunities(
      ThreeCliquesInARow(), GreedyModularityPartitioner(), options);
  ASSERT_EQ(paper.NumCommunities(), 3);
  ASSERT_FALSE(paper.splits.empty());
  EXPECT_GT(paper.splits[0].modularity, 0.3);
  EXPECT_NEAR(paper.splits[0].max_part_conductance, 0.4, 1e-9);

  options.max_part_conductance = 0.3;
  const CommunityPartition refused = DetectCommunities(
      ThreeCliquesInARow(), GreedyModularityPartitioner(), options);
  EXPECT_EQ(refused.NumCommunities(), 1);
  ASSERT_EQ(refused.splits.size(), 1u);
  EXPECT_FALSE(refused.splits[0].accepted);
  EXPECT_NEAR(refused.splits[0].max_part_conductance, 0.4, 1e-9);

  // Holding its whole component, the graph is still cut for the parallel
  // work (the balance rule), into CNM's parts.
  options.max_community_fraction = 0.5;
  const CommunityPartition balanced = DetectCommunities(
      ThreeCliquesInARow(), GreedyModularityPartitioner(), options);
  EXPECT_EQ(balanced.NumCommunities(), 3);
  ASSERT_FALSE(balanced.splits.empty());
  EXPECT_TRUE(balanced.splits[0].balance);
  options.max_community_fraction = 1;

  // Clear communities are still split: two cliques joined by one edge.
  WeightedGraph two_cliques;
  AddClique(/*first=*/0, /*size=*/25, /*weight=*/1, &two_cliques);
  AddClique(/*first=*/25, /*size=*/25, /*weight=*/1, &two_cliques);
  two_cliques.edges.push_back({3, 30, 1});
  EXPECT_EQ(
      DetectCommunities(two_cliques, GreedyModularityPartitioner(), options)
          .NumCommunities(),
      2);
}

TEST(DetectCommunities, APartThatIsNoCommunityRefusesTheSplit) {
  // Two cliques of 40 joined through a clique of 8 that has 40 edges to
  // each: the connector is no community (conductance 40 * 2 / (56 + 80)).
  WeightedGraph graph;
  AddClique(/*first=*/0, /*size=*/40, /*weight=*/1, &graph);
  AddClique(/*first=*/40, /*size=*/8, /*weight=*/1, &graph);
  AddClique(/*first=*/48, /*size=*/40, /*weight=*/1, &graph);
  for (int i = 0; i < 40; ++i) {
    graph.edges.push_back({i, 40 + i % 8, 1});
    graph.edges.push_back({48 + i, 40 + (i + 3) % 8, 1});
  }
  CommunityDetectionOptions options = Options(/*min_community_size=*/5);
  options.max_community_fraction = 1;  // no balance split
  options.max_part_conductance = 1;    // the threshold alone, as the paper
  const CommunityPartition paper =
      DetectCommunities(graph, GreedyModularityPartitioner(), options);
  ASSERT_EQ(paper.NumCommunities(), 3);
  EXPECT_EQ(NumCommunitiesAmong(paper, 40, 8), 1);

  options.max_part_conductance = 0.3;
  const CommunityPartition refused =
      DetectCommunities(graph, GreedyModularityPartitioner(), options);
  EXPECT_EQ(refused.NumCommunities(), 1);
  ASSERT_FALSE(refused.splits.empty());
  EXPECT_GT(refused.splits[0].max_part_conductance, 0.3);
  EXPECT_FALSE(refused.splits[0].accepted);
}

// The smallest share of a landmark cluster's images that one community
// holds, over the clusters of a generated open chain (the benchmark's
// `chain_s1`: 4 landmarks of 80 images, walkways of 60).
double SmallestClusterShareInOneCommunity(
    const CommunityDetectionOptions& options) {
  SyntheticSceneOptions scene_options;
  scene_options.num_clusters = 4;
  scene_options.num_images_per_cluster = 80;
  scene_options.num_images_per_link = 60;
  scene_options.close_loop = false;
  scene_options.single_camera = false;
  scene_options.focal_length_noise = 0.05;
  scene_options.keypoint_noise = 1.0;
  scene_options.num_false_pairs = 30;
  scene_options.seed = 1;
  const std::shared_ptr<Database> database = Database::Open(
      std::filesystem::path(CreateTestFolder()) / "database.db");
  SyntheticScene scene;
  SynthesizeCommunityScene(scene_options, &scene, database.get());
  const ViewGraph view_graph = ViewGraph::Read(*database, 15);
  const CommunityPartition partition =
      DetectCommunities(view_graph.ToWeightedGraph(ViewGraphEdgeWeight::kUnit),
                        GreedyModularityPartitioner(),
                        options);

  // Images per (cluster, community).
  std::map<int, std::map<int, int>> counts;
  for (int vertex = 0; vertex < static_cast<int>(view_graph.NumVertices());
       ++vertex) {
    const int cluster =
        scene.image_cluster.at(view_graph.ImageIds().at(vertex));
    if (cluster >= 0) {
      ++counts[cluster][partition.membership[vertex]];
    }
  }
  double smallest_share = 1.0;
  for (const auto& cluster_and_counts : counts) {
    int total = 0;
    int largest = 0;
    for (const auto& community_and_count : cluster_and_counts.second) {
      total += community_and_count.second;
      largest = std::max(largest, community_and_count.second);
    }
    smallest_share =
        std::min(smallest_share, static_cast<double>(largest) / total);
  }
  return smallest_share;
}

TEST(DetectCommunities, LandmarkClustersOfAnOpenChainAreNotCutInHalf) {
  // The paper's rule alone cuts a landmark cluster in two at Qmax 0.30-0.33
  // (halves sharing 966 of their edges on this draw).
  CommunityDetectionOptions paper;
  paper.max_part_conductance = 1;
  EXPECT_LT(SmallestClusterShareInOneCommunity(paper), 0.8);
  // With the conductance rule every cluster stays (almost) whole.
  EXPECT_GT(SmallestClusterShareInOneCommunity(CommunityDetectionOptions()),
            0.9);
}

TEST(CommunityDetectionOptions, Check) {
  CommunityDetectionOptions options;
  EXPECT_TRUE(options.Check());
  options.modularity_threshold = 1.0;
  EXPECT_FALSE(options.Check());
  options.modularity_threshold = -0.1;
  EXPECT_FALSE(options.Check());
  options.modularity_threshold = 0.3;
  options.min_community_size = 1;
  EXPECT_FALSE(options.Check());
  options.min_community_size = 20;
  options.max_part_conductance = 0;
  EXPECT_FALSE(options.Check());
  options.max_part_conductance = 1.5;
  EXPECT_FALSE(options.Check());
  options.max_part_conductance = 0.3;
}

}  // namespace
}  // namespace colmap
