#include "colmap_ext/partition/view_graph.h"

#include "colmap_ext/util/union_find.h"

#include "colmap/util/logging.h"

#include <algorithm>
#include <map>
#include <numeric>

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

std::vector<std::vector<int>> WeightedGraph::ConnectedComponents() const {
  DisjointSets sets(num_vertices);
  for (const Edge& edge : edges) {
    sets.Union(edge.vertex1, edge.vertex2);
  }

  std::map<int, std::vector<int>> components_by_root;
  for (int vertex = 0; vertex < num_vertices; ++vertex) {
    components_by_root[sets.Find(vertex)].push_back(vertex);
  }
  std::vector<std::vector<int>> components;
  components.reserve(components_by_root.size());
  for (auto& root_and_component : components_by_root) {
    components.push_back(std::move(root_and_component.second));
  }
  std::stable_sort(components.begin(),
                   components.end(),
                   [](const std::vector<int>& a, const std::vector<int>& b) {
                     return a.size() > b.size();
                   });
  return components;
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
  switch (weight) {
    case ViewGraphEdgeWeight::kUnit:
      return "unit";
    case ViewGraphEdgeWeight::kNumInliers:
      return "num_inliers";
  }
  return "unknown";
}

ViewGraph ViewGraph::Read(const Database& database,
                          const int min_num_matches,
                          const std::unordered_set<std::string>& image_names) {
  std::vector<std::pair<image_t, image_t>> image_pairs;
  std::vector<int> num_inliers;
  for (const auto& [pair_id, pair_num_inliers] :
       database.ReadTwoViewGeometryNumInliers()) {
    image_pairs.push_back(PairIdToImagePair(pair_id));
    num_inliers.push_back(pair_num_inliers);
  }
  // The pairs read are those with inliers; the database counts all.
  const size_t num_failed_pairs =
      database.NumVerifiedImagePairs() - image_pairs.size();

  std::unordered_map<image_t, std::string> name_of_image;
  for (const Image& image : database.ReadAllImages()) {
    if (image_names.empty() || image_names.count(image.Name()) > 0) {
      name_of_image.emplace(image.ImageId(), image.Name());
    }
  }
  if (!image_names.empty()) {
    size_t num_kept = 0;
    for (size_t i = 0; i < image_pairs.size(); ++i) {
      if (name_of_image.count(image_pairs[i].first) > 0 &&
          name_of_image.count(image_pairs[i].second) > 0) {
        image_pairs[num_kept] = image_pairs[i];
        num_inliers[num_kept] = num_inliers[i];
        ++num_kept;
      }
    }
    image_pairs.resize(num_kept);
    num_inliers.resize(num_kept);
  }
  ViewGraph view_graph =
      Create(image_pairs, num_inliers, min_num_matches, name_of_image);
  view_graph.num_failed_pairs_ = num_failed_pairs;
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
    image_t image_id1 = image_pairs[i].first;
    image_t image_id2 = image_pairs[i].second;
    if (image_id1 == image_id2 || num_inliers[i] < min_num_matches) {
      continue;
    }
    if (image_id1 > image_id2) {
      std::swap(image_id1, image_id2);
    }
    int& pair_num_inliers = pair_to_num_inliers[{image_id1, image_id2}];
    pair_num_inliers = std::max(pair_num_inliers, num_inliers[i]);
  }

  // Vertices in ascending image id order, so that the graph does not depend
  // on the order in which the database returns the pairs.
  ViewGraph graph;
  for (const auto& pair_and_num_inliers : pair_to_num_inliers) {
    graph.image_ids_.push_back(pair_and_num_inliers.first.first);
    graph.image_ids_.push_back(pair_and_num_inliers.first.second);
  }
  std::sort(graph.image_ids_.begin(), graph.image_ids_.end());
  graph.image_ids_.erase(
      std::unique(graph.image_ids_.begin(), graph.image_ids_.end()),
      graph.image_ids_.end());
  std::unordered_map<image_t, int> image_id_to_vertex;
  for (size_t vertex = 0; vertex < graph.image_ids_.size(); ++vertex) {
    image_id_to_vertex.emplace(graph.image_ids_[vertex],
                               static_cast<int>(vertex));
  }

  graph.edges_.reserve(pair_to_num_inliers.size());
  for (const auto& pair_and_num_inliers : pair_to_num_inliers) {
    graph.edges_.push_back(
        {image_id_to_vertex.at(pair_and_num_inliers.first.first),
         image_id_to_vertex.at(pair_and_num_inliers.first.second),
         pair_and_num_inliers.second});
  }

  graph.SetFrames({});

  graph.image_names_.reserve(graph.image_ids_.size());
  for (const image_t image_id : graph.image_ids_) {
    const auto it = image_names.find(image_id);
    graph.image_names_.push_back(it != image_names.end()
                                     ? it->second
                                     : "image" + std::to_string(image_id));
  }
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
  if (frame_vertices_.size() == image_ids_.size()) {
    return ToWeightedGraph(weight);
  }
  std::vector<int> frame_of_vertex(image_ids_.size());
  for (size_t frame = 0; frame < frame_vertices_.size(); ++frame) {
    for (const int vertex : frame_vertices_[frame]) {
      frame_of_vertex[vertex] = static_cast<int>(frame);
    }
  }
  std::map<std::pair<int, int>, double> weight_of_frame_pair;
  for (const WeightedGraph::Edge& edge : ToWeightedGraph(weight).edges) {
    int frame1 = frame_of_vertex[edge.vertex1];
    int frame2 = frame_of_vertex[edge.vertex2];
    if (frame1 == frame2) {
      continue;
    }
    if (frame1 > frame2) {
      std::swap(frame1, frame2);
    }
    weight_of_frame_pair[{frame1, frame2}] += edge.weight;
  }
  WeightedGraph graph;
  graph.num_vertices = static_cast<int>(frame_vertices_.size());
  for (const auto& [frames, frame_pair_weight] : weight_of_frame_pair) {
    graph.edges.push_back({frames.first, frames.second, frame_pair_weight});
  }
  return graph;
}

}  // namespace colmap
