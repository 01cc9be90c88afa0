#include "colmap_ext/partition/view_graph.h"

#include "colmap_ext/util/union_find.h"

#include "colmap/util/logging.h"

#include <algorithm>
#include <map>

namespace colmap {

WeightedGraph WeightedGraph::InducedSubgraph(
    const std::vector<int>& vertices) const {
  std::vector<int> new_index(num_vertices, -1);
  for (size_t i = 0; i < vertices.size(); ++i) {
    THROW_CHECK_GE(vertices[i], 0);
    THROW_CHECK_LT(vertices[i], num_vertices);
    new_index[vertices[i]] = static_cast<int>(i);
  }
  WeightedGraph subgraph;
  subgraph.num_vertices = static_cast<int>(vertices.size());
  for (const Edge& edge : edges) {
    const int vertex1 = new_index[edge.vertex1];
    const int vertex2 = new_index[edge.vertex2];
    if (vertex1 >= 0 && vertex2 >= 0) {
      subgraph.edges.push_back({vertex1, vertex2, edge.weight});
    }
  }
  return subgraph;
}

WeightedGraph WeightedGraph::Simplified() const {
  std::map<std::pair<int, int>, double> weights;
  for (const Edge& edge : edges) {
    if (edge.vertex1 != edge.vertex2) {
      weights[std::minmax(edge.vertex1, edge.vertex2)] += edge.weight;
    }
  }
  WeightedGraph graph;
  graph.num_vertices = num_vertices;
  for (const auto& [vertices, weight] : weights) {
    graph.edges.push_back({vertices.first, vertices.second, weight});
  }
  return graph;
}

std::vector<std::vector<int>> WeightedGraph::ConnectedComponents() const {
  std::vector<std::pair<int, int>> vertex_pairs;
  for (const Edge& edge : edges) {
    vertex_pairs.emplace_back(edge.vertex1, edge.vertex2);
  }
  return GroupVertices(ConnectedComponentLabels(num_vertices, vertex_pairs));
}

std::vector<std::vector<int>> GroupVertices(const std::vector<int>& labels) {
  std::map<int, std::vector<int>> groups_by_label;
  for (size_t vertex = 0; vertex < labels.size(); ++vertex) {
    groups_by_label[labels[vertex]].push_back(static_cast<int>(vertex));
  }
  std::vector<std::vector<int>> groups;
  for (auto& [label, group] : groups_by_label) {
    groups.push_back(std::move(group));
  }
  std::sort(groups.begin(),
            groups.end(),
            [](const std::vector<int>& a, const std::vector<int>& b) {
              return a.size() != b.size() ? a.size() > b.size()
                                          : a.front() < b.front();
            });
  return groups;
}

ViewGraphEdgeWeight ViewGraphEdgeWeightFromString(const std::string& name) {
  if (name == "unit") {
    return ViewGraphEdgeWeight::kUnit;
  } else if (name == "num_inliers") {
    return ViewGraphEdgeWeight::kNumInliers;
  }
  LOG(FATAL_THROW) << "Unknown edge weight type '" << name
                   << "': use 'unit' or 'num_inliers'.";
  return ViewGraphEdgeWeight::kUnit;
}

std::string ViewGraphEdgeWeightToString(const ViewGraphEdgeWeight weight) {
  return weight == ViewGraphEdgeWeight::kUnit ? "unit" : "num_inliers";
}

ViewGraph ViewGraph::Read(const Database& database,
                          const int min_num_matches,
                          const std::unordered_set<std::string>& image_names) {
  std::unordered_map<image_t, std::string> name_of_image;
  for (const Image& image : database.ReadAllImages()) {
    if (image_names.empty() || image_names.count(image.Name()) > 0) {
      name_of_image.emplace(image.ImageId(), image.Name());
    }
  }
  const std::vector<std::pair<image_pair_t, int>> all_num_inliers =
      database.ReadTwoViewGeometryNumInliers();
  std::vector<std::pair<image_t, image_t>> image_pairs;
  std::vector<int> num_inliers;
  for (const auto& [pair_id, pair_num_inliers] : all_num_inliers) {
    const std::pair<image_t, image_t> image_pair = PairIdToImagePair(pair_id);
    if (image_names.empty() || (name_of_image.count(image_pair.first) > 0 &&
                                name_of_image.count(image_pair.second) > 0)) {
      image_pairs.push_back(image_pair);
      num_inliers.push_back(pair_num_inliers);
    }
  }
  ViewGraph view_graph =
      Create(image_pairs, num_inliers, min_num_matches, name_of_image);
  // The pairs read are those with inliers; the database counts all.
  view_graph.num_failed_pairs_ =
      database.NumVerifiedImagePairs() - all_num_inliers.size();
  std::unordered_map<image_t, frame_t> frame_of_image;
  for (const Frame& frame : database.ReadAllFrames()) {
    for (const data_t& data_id : frame.ImageIds()) {
      frame_of_image.emplace(static_cast<image_t>(data_id.id),
                             frame.FrameId());
    }
  }
  view_graph.SetFrames(frame_of_image);
  return view_graph;
}

ViewGraph ViewGraph::Create(
    const std::vector<std::pair<image_t, image_t>>& image_pairs,
    const std::vector<int>& num_inliers,
    const int min_num_matches,
    const std::unordered_map<image_t, std::string>& image_names) {
  THROW_CHECK_EQ(image_pairs.size(), num_inliers.size());

  // Keep the strongest entry of each unordered pair; a well-formed database
  // has one entry per pair anyway.
  std::map<std::pair<image_t, image_t>, int> pair_to_num_inliers;
  for (size_t i = 0; i < image_pairs.size(); ++i) {
    const auto [image_id1, image_id2] =
        std::minmax(image_pairs[i].first, image_pairs[i].second);
    if (image_id1 == image_id2 || num_inliers[i] < min_num_matches) {
      continue;
    }
    int& pair_num_inliers = pair_to_num_inliers[{image_id1, image_id2}];
    pair_num_inliers = std::max(pair_num_inliers, num_inliers[i]);
  }

  // Vertices in ascending image id order, so that the graph does not depend
  // on the order in which the database returns the pairs.
  ViewGraph graph;
  std::map<image_t, int> vertex_of_image;
  for (const auto& pair_and_num_inliers : pair_to_num_inliers) {
    vertex_of_image.emplace(pair_and_num_inliers.first.first, 0);
    vertex_of_image.emplace(pair_and_num_inliers.first.second, 0);
  }
  for (auto& [image_id, vertex] : vertex_of_image) {
    vertex = static_cast<int>(graph.image_ids_.size());
    graph.image_ids_.push_back(image_id);
    const auto it = image_names.find(image_id);
    graph.image_names_.push_back(it != image_names.end()
                                     ? it->second
                                     : "image" + std::to_string(image_id));
  }
  graph.edges_.reserve(pair_to_num_inliers.size());
  for (const auto& [image_pair, pair_num_inliers] : pair_to_num_inliers) {
    graph.edges_.push_back({vertex_of_image.at(image_pair.first),
                            vertex_of_image.at(image_pair.second),
                            pair_num_inliers});
  }
  graph.SetFrames({});
  return graph;
}

WeightedGraph ViewGraph::ToWeightedGraph(
    const ViewGraphEdgeWeight weight) const {
  WeightedGraph graph;
  graph.num_vertices = static_cast<int>(image_ids_.size());
  graph.edges.reserve(edges_.size());
  for (const Edge& edge : edges_) {
    graph.edges.push_back({edge.vertex1,
                           edge.vertex2,
                           weight == ViewGraphEdgeWeight::kUnit
                               ? 1.0
                               : static_cast<double>(edge.num_inliers)});
  }
  return graph;
}

void ViewGraph::SetFrames(
    const std::unordered_map<image_t, frame_t>& frame_of_image) {
  frame_vertices_.clear();
  std::unordered_map<frame_t, size_t> index_of_frame;
  for (size_t vertex = 0; vertex < image_ids_.size(); ++vertex) {
    const auto it = frame_of_image.find(image_ids_[vertex]);
    if (it != frame_of_image.end()) {
      const auto inserted =
          index_of_frame.emplace(it->second, frame_vertices_.size());
      if (!inserted.second) {
        frame_vertices_[inserted.first->second].push_back(
            static_cast<int>(vertex));
        continue;
      }
    }
    frame_vertices_.push_back({static_cast<int>(vertex)});
  }
}

WeightedGraph ViewGraph::ToFrameGraph(const ViewGraphEdgeWeight weight) const {
  WeightedGraph graph = ToWeightedGraph(weight);
  if (frame_vertices_.size() == image_ids_.size()) {
    return graph;
  }
  std::vector<int> frame_of_vertex(image_ids_.size());
  for (size_t frame = 0; frame < frame_vertices_.size(); ++frame) {
    for (const int vertex : frame_vertices_[frame]) {
      frame_of_vertex[vertex] = static_cast<int>(frame);
    }
  }
  graph.num_vertices = static_cast<int>(frame_vertices_.size());
  for (WeightedGraph::Edge& edge : graph.edges) {
    edge.vertex1 = frame_of_vertex[edge.vertex1];
    edge.vertex2 = frame_of_vertex[edge.vertex2];
  }
  return graph.Simplified();
}

}  // namespace colmap
