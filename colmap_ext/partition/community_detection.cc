#include "colmap_ext/partition/community_detection.h"
#include "colmap_ext/util/option_check.h"

#include "colmap/util/logging.h"
#include "colmap/util/string.h"

#include <algorithm>
#include <map>

#include <igraph.h>

namespace colmap {
namespace {

// Bound on the recursion depth, a guard against pathological inputs.
constexpr int kMaxRecursionDepth = 32;

#define IGRAPH_CALL(expr)                                                 \
  do {                                                                    \
    const igraph_error_t igraph_status = (expr);                          \
    THROW_CHECK_EQ(igraph_status, IGRAPH_SUCCESS)                         \
        << "igraph: " << #expr << ": " << igraph_strerror(igraph_status); \
  } while (false)

// Owner of an igraph C object, so that every path out frees it: made by
// `init(&object, args...)` (igraph_create, igraph_*_init).
template <typename T, auto Destroy>
struct IgraphObject {
  template <typename Init, typename... Args>
  explicit IgraphObject(const Init init, const Args... args) {
    IGRAPH_CALL(init(&object, args...));
  }
  ~IgraphObject() { Destroy(&object); }
  T object;
};
using IgraphIntVector =
    IgraphObject<igraph_vector_int_t, igraph_vector_int_destroy>;
using IgraphRealVector = IgraphObject<igraph_vector_t, igraph_vector_destroy>;

// Relabels communities to 0..K-1, largest first, ties by smallest vertex.
std::vector<int> RelabelBySize(const std::vector<int>& membership) {
  const std::vector<std::vector<int>> communities = GroupVertices(membership);
  std::vector<int> relabeled(membership.size(), -1);
  for (size_t label = 0; label < communities.size(); ++label) {
    for (const int vertex : communities[label]) {
      relabeled[vertex] = static_cast<int>(label);
    }
  }
  return relabeled;
}

// Merges every community smaller than min_size into the community with the
// most edges to it (ties: the larger one, then the smaller label), smallest
// community first, until no small community has a neighbour left.
void MergeSmallCommunities(const WeightedGraph& graph,
                           const int min_size,
                           std::vector<int>* membership) {
  std::map<int, int> sizes;
  for (const int label : *membership) {
    ++sizes[label];
  }
  // Number of view-graph edges between each pair of communities.
  std::map<int, std::map<int, int>> num_cross_edges;
  for (const auto& edge : graph.edges) {
    const int label1 = (*membership)[edge.vertex1];
    const int label2 = (*membership)[edge.vertex2];
    if (label1 != label2) {
      ++num_cross_edges[label1][label2];
      ++num_cross_edges[label2][label1];
    }
  }
  std::map<int, int> merged_into;  // label -> label it was merged into

  while (true) {
    // The smallest community below min_size that has a neighbour.
    int label = -1;
    for (const auto& [candidate, size] : sizes) {
      if (size < min_size && !num_cross_edges[candidate].empty() &&
          (label == -1 || size < sizes.at(label))) {
        label = candidate;
      }
    }
    if (label == -1) {
      break;
    }

    int target = -1;
    for (const auto& [other, count] : num_cross_edges.at(label)) {
      if (target == -1 || count > num_cross_edges.at(label).at(target) ||
          (count == num_cross_edges.at(label).at(target) &&
           sizes.at(other) > sizes.at(target))) {
        target = other;
      }
    }

    // Move the cross edges of `label` to `target`.
    for (const auto& [other, count] : num_cross_edges.at(label)) {
      num_cross_edges[other].erase(label);
      if (other != target) {
        num_cross_edges[target][other] += count;
        num_cross_edges[other][target] += count;
      }
    }
    num_cross_edges.erase(label);
    sizes[target] += sizes.at(label);
    sizes.erase(label);
    merged_into[label] = target;
  }

  for (int& vertex_label : *membership) {
    while (merged_into.count(vertex_label) > 0) {
      vertex_label = merged_into.at(vertex_label);
    }
  }
}

// The largest conductance cut(P) / vol(P) of a part P of `membership`
// (labels of the vertices of `graph`) within `graph` (weighted), the parts
// under min_community_size counted with the sibling MergeSmallCommunities
// gives them.
double MaxPartConductance(const WeightedGraph& graph,
                          const int min_community_size,
                          const std::vector<int>& membership) {
  std::vector<int> merged = membership;
  MergeSmallCommunities(graph, min_community_size, &merged);
  std::map<int, double> volume;
  std::map<int, double> cut;
  for (const auto& edge : graph.edges) {
    const int label1 = merged[edge.vertex1];
    const int label2 = merged[edge.vertex2];
    volume[label1] += edge.weight;
    volume[label2] += edge.weight;
    if (label1 != label2) {
      cut[label1] += edge.weight;
      cut[label2] += edge.weight;
    }
  }
  double max_conductance = 0.0;
  for (const auto& [label, label_cut] : cut) {
    max_conductance = std::max(max_conductance, label_cut / volume.at(label));
  }
  return max_conductance;
}

}  // namespace

GraphPartitioner::Result GreedyModularityPartitioner::Partition(
    const WeightedGraph& graph) const {
  // igraph aborts the process on errors by default; report them as error
  // codes instead, which IGRAPH_CALL turns into exceptions.
  [[maybe_unused]] static const bool kIgraphErrorCodes = [] {
    igraph_set_error_handler(igraph_error_handler_ignore);
    igraph_set_warning_handler(igraph_warning_handler_ignore);
    return true;
  }();
  for (const auto& edge : graph.edges) {
    if (edge.vertex1 != edge.vertex2) {
      THROW_CHECK_GT(edge.weight, 0.0) << "Edge weights must be positive.";
    }
  }
  // CNM needs a simple graph.
  const std::vector<WeightedGraph::Edge> edges = graph.Simplified().edges;
  THROW_CHECK_GE(graph.num_vertices, 2);
  THROW_CHECK(!edges.empty());

  const auto num_edges = static_cast<igraph_integer_t>(edges.size());
  IgraphIntVector igraph_edges(igraph_vector_int_init, 2 * num_edges);
  IgraphRealVector weights(igraph_vector_init, num_edges);
  for (size_t i = 0; i < edges.size(); ++i) {
    VECTOR(igraph_edges.object)[2 * i] = edges[i].vertex1;
    VECTOR(igraph_edges.object)[2 * i + 1] = edges[i].vertex2;
    VECTOR(weights.object)[i] = edges[i].weight;
  }
  IgraphObject<igraph_t, igraph_destroy> igraph_graph(igraph_create,
                                                      &igraph_edges.object,
                                                      graph.num_vertices,
                                                      IGRAPH_UNDIRECTED);

  IgraphObject<igraph_matrix_int_t, igraph_matrix_int_destroy> merges(
      igraph_matrix_int_init, 0, 0);
  IgraphRealVector modularity(igraph_vector_init, 0);
  IgraphIntVector membership(igraph_vector_int_init, 0);
  IGRAPH_CALL(igraph_community_fastgreedy(&igraph_graph.object,
                                          &weights.object,
                                          &merges.object,
                                          &modularity.object,
                                          &membership.object));

  Result result;
  result.modularity = igraph_vector_max(&modularity.object);
  const igraph_integer_t* labels = VECTOR(membership.object);
  result.membership = RelabelBySize(
      std::vector<int>(labels, labels + graph.num_vertices));
  result.num_communities =
      1 + *std::max_element(result.membership.begin(), result.membership.end());
  return result;
}

bool CommunityDetectionOptions::Check() const {
  bool valid = CheckFlag(modularity_threshold >= 0 && modularity_threshold < 1,
                         "modularity_threshold",
                         modularity_threshold,
                         "in [0, 1) (the CSfM paper uses 0.3)");
  valid &= CheckFlag(min_community_size >= 2,
                     "min_community_size",
                     min_community_size,
                     "at least 2 (the CSfM paper uses 20)");
  valid &= CheckFlag(max_community_fraction > 0 && max_community_fraction <= 1,
                     "max_community_fraction",
                     max_community_fraction,
                     "in (0, 1] (1: split by the threshold only)");
  valid &= CheckFlag(max_part_conductance > 0 && max_part_conductance <= 1,
                     "partition_max_part_conductance",
                     max_part_conductance,
                     "in (0, 1] (1: split by the threshold only)");
  return valid;
}

int CommunityPartition::NumCommunities() const {
  return membership.empty()
             ? 0
             : 1 + *std::max_element(membership.begin(), membership.end());
}

std::vector<std::vector<int>> CommunityPartition::Communities() const {
  std::vector<std::vector<int>> communities(NumCommunities());
  for (size_t vertex = 0; vertex < membership.size(); ++vertex) {
    communities[membership[vertex]].push_back(static_cast<int>(vertex));
  }
  return communities;
}

double CommunityPartition::MaxModularity() const {
  double max_modularity = 0.0;
  for (const Split& split : splits) {
    max_modularity = std::max(max_modularity, split.modularity);
  }
  return max_modularity;
}

CommunityPartition DetectCommunities(const WeightedGraph& graph,
                                     const GraphPartitioner& partitioner,
                                     const CommunityDetectionOptions& options) {
  THROW_CHECK(options.Check());
  for (const auto& edge : graph.edges) {
    THROW_CHECK_GE(edge.vertex1, 0);
    THROW_CHECK_LT(edge.vertex1, graph.num_vertices);
    THROW_CHECK_GE(edge.vertex2, 0);
    THROW_CHECK_LT(edge.vertex2, graph.num_vertices);
  }

  CommunityPartition partition;
  partition.membership.assign(graph.num_vertices, -1);

  // Depth-first recursion over vertex sets of `graph`, each connected.
  struct Pending {
    std::vector<int> vertices;
    int depth = 0;
    // Images of the connected component it belongs to.
    int component_size = 0;
    // Whether it is a part of a balance split (see below).
    bool balanced = false;
  };
  std::vector<Pending> pending;
  const std::vector<std::vector<int>> components = graph.ConnectedComponents();
  partition.num_components = static_cast<int>(components.size());
  for (auto it = components.rbegin(); it != components.rend(); ++it) {
    pending.push_back({*it, 0, static_cast<int>(it->size())});
  }

  int num_final = 0;
  while (!pending.empty()) {
    Pending current = std::move(pending.back());
    pending.pop_back();

    const WeightedGraph subgraph = graph.InducedSubgraph(current.vertices);
    if (subgraph.num_vertices >= 2 && !subgraph.edges.empty() &&
        current.depth < kMaxRecursionDepth) {
      const GraphPartitioner::Result result = partitioner.Partition(subgraph);
      CommunityPartition::Split record;
      record.depth = current.depth;
      record.num_vertices = subgraph.num_vertices;
      record.num_edges = static_cast<int>(subgraph.edges.size());
      record.modularity = result.modularity;
      record.num_parts = result.num_communities;
      // A split by the threshold whose parts are communities.
      if (result.num_communities > 1 &&
          result.modularity > options.modularity_threshold) {
        record.max_part_conductance = MaxPartConductance(
            subgraph, options.min_community_size, result.membership);
        record.accepted =
            record.max_part_conductance <= options.max_part_conductance;
      }
      if (!record.accepted && result.num_communities > 1 && !current.balanced &&
          current.vertices.size() >
              options.max_community_fraction * current.component_size) {
        std::vector<int> part_sizes(result.num_communities, 0);
        for (const int label : result.membership) {
          ++part_sizes[label];
        }
        std::sort(part_sizes.begin(), part_sizes.end(), std::greater<int>());
        record.balance = part_sizes[1] >= options.min_community_size;
        record.accepted = record.balance;
      }
      partition.splits.push_back(record);
      LOG(INFO) << StringPrintf(
          "%*sSplit %d images (%d edges): Qmax = %.4f, %d parts (largest "
          "conductance %.3f) -> %s",
          2 * current.depth,
          "",
          record.num_vertices,
          record.num_edges,
          record.modularity,
          record.num_parts,
          record.max_part_conductance,
          record.balance ? "split (more than its share of the component)"
          : record.accepted
              ? "split"
              : (record.max_part_conductance > options.max_part_conductance
                     ? "kept as one community (a part is no community)"
                     : "kept as one community"));

      if (record.accepted) {
        std::vector<std::vector<int>> parts(result.num_communities);
        for (int i = 0; i < subgraph.num_vertices; ++i) {
          parts[result.membership[i]].push_back(current.vertices[i]);
        }
        // A partitioner may return a community that is not connected; each
        // of its connected pieces is a community of its own.
        const size_t num_pending = pending.size();
        for (const std::vector<int>& part : parts) {
          for (const std::vector<int>& piece :
               graph.InducedSubgraph(part).ConnectedComponents()) {
            pending.push_back({{},
                               current.depth + 1,
                               current.component_size,
                               current.balanced || record.balance});
            for (const int i : piece) {
              pending.back().vertices.push_back(part[i]);
            }
          }
        }
        // Last pushed, first handled: the first piece first.
        std::reverse(pending.begin() + num_pending, pending.end());
        continue;
      }
    }
    for (const int vertex : current.vertices) {
      partition.membership[vertex] = num_final;
    }
    ++num_final;
  }

  partition.num_communities_before_merge = num_final;
  MergeSmallCommunities(
      graph, options.min_community_size, &partition.membership);
  partition.membership = RelabelBySize(partition.membership);
  return partition;
}

std::vector<std::vector<int>> ExtendCommunities(
    const WeightedGraph& graph,
    const CommunityPartition& partition,
    const int num_overlap_images) {
  THROW_CHECK_GE(num_overlap_images, 0);
  THROW_CHECK_EQ(partition.membership.size(),
                 static_cast<size_t>(graph.num_vertices));
  std::vector<std::vector<std::pair<int, double>>> adjacency(
      graph.num_vertices);
  for (const auto& edge : graph.edges) {
    adjacency[edge.vertex1].emplace_back(edge.vertex2, edge.weight);
    adjacency[edge.vertex2].emplace_back(edge.vertex1, edge.weight);
  }

  std::vector<std::vector<int>> extended = partition.Communities();
  if (num_overlap_images == 0) {
    return extended;
  }
  const std::vector<int>& membership = partition.membership;
  for (size_t community = 0; community < extended.size(); ++community) {
    std::vector<char> inside(graph.num_vertices, 0);
    for (const int vertex : extended[community]) {
      inside[vertex] = 1;
    }
    // Links (edge count, summed weight) of outside vertices to the inside.
    std::map<int, std::pair<int, double>> links;
    auto add_links = [&](const int vertex) {
      for (const auto& [neighbor, weight] : adjacency[vertex]) {
        if (!inside[neighbor]) {
          ++links[neighbor].first;
          links[neighbor].second += weight;
        }
      }
    };
    for (const int vertex : extended[community]) {
      add_links(vertex);
    }
    std::map<int, int> num_added;  // per neighbouring community
    while (true) {
      int best = -1;
      for (const auto& [vertex, link] : links) {
        // More edges, then a larger summed weight.
        if (!inside[vertex] &&
            num_added[membership[vertex]] < num_overlap_images &&
            (best == -1 || link > links[best])) {
          best = vertex;
        }
      }
      if (best == -1) {
        break;
      }
      inside[best] = 1;
      ++num_added[membership[best]];
      extended[community].push_back(best);
      links.erase(best);
      add_links(best);
    }
  }
  return extended;
}

}  // namespace colmap
