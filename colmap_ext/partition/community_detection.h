// Community detection on the view graph.
//
// CSfM (Cui et al., ICIP 2017), section 2: greedy modularity maximisation
// (Clauset, Newman and Moore, Phys. Rev. E 70, 2004) cuts each connected
// component recursively at its peak modularity Q_max, where
//     Q = 1/(2m) sum_ij (A_ij - d_i d_j / (2m)) delta(U_i, U_j),
// only where Q_max exceeds a threshold (0.3); communities under N images (20)
// join the neighbour with the most edges to them. Two rules are added
// (CommunityDetectionOptions): max_part_conductance and
// max_community_fraction. A `GraphPartitioner` splits one level, so that
// another algorithm (Leiden, say) can take greedy modularity's place.

#pragma once

#include "colmap_ext/partition/view_graph.h"

#include <vector>

namespace colmap {

// Splits a graph once into communities.
class GraphPartitioner {
 public:
  struct Result {
    // Community of each vertex, 0..num_communities-1.
    std::vector<int> membership;
    int num_communities = 0;
    // Modularity of `membership` (for greedy modularity: Q_max).
    double modularity = 0.0;
  };

  virtual ~GraphPartitioner() = default;

  // The graph has at least two vertices and at least one edge.
  virtual Result Partition(const WeightedGraph& graph) const = 0;
};

// Clauset-Newman-Moore greedy modularity (igraph_community_fastgreedy),
// taking the dendrogram cut at Q_max. Uses the graph's edge weights.
class GreedyModularityPartitioner : public GraphPartitioner {
 public:
  Result Partition(const WeightedGraph& graph) const override;
};

struct CommunityDetectionOptions {
  // Split a (sub)graph only where its peak modularity exceeds this value.
  double modularity_threshold = 0.3;

  // Communities smaller than this are merged into a neighbouring community.
  int min_community_size = 20;

  // Below 1, a (sub)graph holding more than this fraction of its connected
  // component is split at its modularity peak even where the peak is below
  // the threshold or a part is no community (max_part_conductance), if at
  // least two parts reach min_community_size, once per branch: more
  // communities for the parallel work on a scene without structure. Such a
  // cut leaves each community's mapper less of the scene to resolve its
  // ambiguities with, so the default is the paper's rule alone.
  double max_community_fraction = 1.0;

  // A split by the threshold is refused where one of its parts (with the
  // parts under min_community_size that would join it) has a conductance
  // above this within the split graph. A chain of overlapping views reaches
  // the threshold without community structure: on an open chain of landmark
  // clusters the threshold alone cuts clusters in two and leaves walkway
  // pieces alone, for the merge to join again; clear splits still stand.
  // 1: the threshold alone, as the paper.
  double max_part_conductance = 0.3;

  bool Check() const;
};

struct CommunityPartition {
  // One record per attempted split, in the order they were attempted.
  struct Split {
    // Recursion depth (0: a whole connected component).
    int depth = 0;
    int num_vertices = 0;
    int num_edges = 0;
    // Peak modularity and the number of parts at the peak.
    double modularity = 0.0;
    int num_parts = 1;
    // Where Qmax exceeds the threshold: the largest conductance of a part
    // within the split graph (see max_part_conductance; 0 otherwise).
    double max_part_conductance = 0.0;
    // Whether the graph was split: modularity exceeded the threshold, or
    // the graph held too large a share of its component (`balance`).
    bool accepted = false;
    bool balance = false;
  };

  // Community of each vertex: 0..NumCommunities()-1, largest first (ties by
  // smallest vertex), -1 never occurs.
  std::vector<int> membership;
  std::vector<Split> splits;
  // Number of connected components of the input graph.
  int num_components = 0;
  // Number of communities before small ones were merged.
  int num_communities_before_merge = 0;

  int NumCommunities() const;
  // The vertices of each community, in ascending order.
  std::vector<std::vector<int>> Communities() const;
  // Largest peak modularity of any split (0 if none was attempted).
  double MaxModularity() const;
};

// Partitions the graph as described at the top of this file.
CommunityPartition DetectCommunities(const WeightedGraph& graph,
                                     const GraphPartitioner& partitioner,
                                     const CommunityDetectionOptions& options);

// Extends every community by images of its neighbours, so that neighbouring
// communities share images and their reconstructions share points (CSfM
// relies on cross edges alone; COLMAP's hierarchical mapper overlaps its
// clusters too). Up to `num_overlap_images` images of each neighbour are
// added greedily, each the outside image with the most edges to the
// community so far (ties: larger summed weight, then smaller vertex): the
// additions grow from the border along the strongest connections. Returns,
// per community, its own vertices (ascending), then the added ones.
std::vector<std::vector<int>> ExtendCommunities(
    const WeightedGraph& graph,
    const CommunityPartition& partition,
    int num_overlap_images);

}  // namespace colmap
