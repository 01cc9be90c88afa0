// The epipolar-geometry graph ("view graph") of a COLMAP database.
//
// CSfM (Cui et al., "CSfM: Community-based Structure from Motion", ICIP 2017),
// section 2: images are vertices, and the pairs with at least
// `min_num_matches` verified inlier matches (the incremental mapper's rule)
// are edges; an image without an edge is not in the graph.

#pragma once

#include "colmap/scene/database.h"
#include "colmap/util/types.h"

#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace colmap {

// An undirected graph on vertices 0..num_vertices-1 with positive edge
// weights: community detection's input, free of any database.
struct WeightedGraph {
  struct Edge {
    int vertex1 = -1;
    int vertex2 = -1;
    double weight = 1.0;
  };

  int num_vertices = 0;
  std::vector<Edge> edges;

  // The subgraph induced by the given vertices. Vertex i of the subgraph is
  // vertices[i] of this graph.
  WeightedGraph InducedSubgraph(const std::vector<int>& vertices) const;

  // The connected components as lists of vertices, largest first, each list
  // sorted ascending.
  std::vector<std::vector<int>> ConnectedComponents() const;

  // The graph with parallel edges joined (weights summed) and self-loops
  // dropped, edges ordered by their (smaller, larger) vertex pair.
  WeightedGraph Simplified() const;
};

// The vertices of each label (`labels[vertex]`), each group ascending, the
// largest first (ties: the smaller first vertex first).
std::vector<std::vector<int>> GroupVertices(const std::vector<int>& labels);

// How the view graph's edges are weighted for community detection.
enum class ViewGraphEdgeWeight {
  // Every edge has weight 1 (A_ij = 1, as in the CSfM paper).
  kUnit,
  // Every edge weighted by its verified inlier matches (where nearly every
  // pair is verified, the unit-weight graph shows no structure).
  kNumInliers,
};

// Parses "unit" or "num_inliers"; throws on anything else.
ViewGraphEdgeWeight ViewGraphEdgeWeightFromString(const std::string& name);
std::string ViewGraphEdgeWeightToString(ViewGraphEdgeWeight weight);

class ViewGraph {
 public:
  struct Edge {
    // Indices into ImageIds().
    int vertex1 = -1;
    int vertex2 = -1;
    int num_inliers = 0;
  };

  // Reads the verified pairs' inlier counts (not the matches: cheap) and the
  // frames (SetFrames); with `image_names`, only the pairs of two images
  // named there (as the incremental mapper's, --image_list_path).
  static ViewGraph Read(
      const Database& database,
      int min_num_matches,
      const std::unordered_set<std::string>& image_names = {});

  // Builds the graph from a list of image pairs with their inlier counts.
  // Pairs below `min_num_matches` are ignored; image names are optional.
  static ViewGraph Create(
      const std::vector<std::pair<image_t, image_t>>& image_pairs,
      const std::vector<int>& num_inliers,
      int min_num_matches,
      const std::unordered_map<image_t, std::string>& image_names = {});

  size_t NumVertices() const { return image_ids_.size(); }
  size_t NumEdges() const { return edges_.size(); }

  const std::vector<image_t>& ImageIds() const { return image_ids_; }
  const std::vector<std::string>& ImageNames() const { return image_names_; }
  const std::vector<Edge>& Edges() const { return edges_; }

  // Image pairs compared and found without inliers (an empty two-view
  // geometry). Where there are any, a pair without a geometry was never
  // compared; where there are none, that cannot be told.
  size_t NumFailedPairs() const { return num_failed_pairs_; }

  WeightedGraph ToWeightedGraph(ViewGraphEdgeWeight weight) const;

  // Groups the vertices by frame: images that `frame_of_image` puts in one
  // frame (one snapshot of a camera rig, which has one pose) are one unit
  // of the partition. Images it does not name are frames of their own.
  void SetFrames(const std::unordered_map<image_t, frame_t>& frame_of_image);

  // The vertices of every frame, each list ascending, frames ordered by
  // their first vertex (without SetFrames, every vertex is a frame).
  const std::vector<std::vector<int>>& FrameVertices() const {
    return frame_vertices_;
  }

  // The graph of frames: a vertex per frame (FrameVertices' order), an edge
  // between two frames weighing as the edges between their images together.
  // Where every frame holds one image, ToWeightedGraph(weight) itself.
  WeightedGraph ToFrameGraph(ViewGraphEdgeWeight weight) const;

 private:
  std::vector<image_t> image_ids_;
  std::vector<std::string> image_names_;
  std::vector<Edge> edges_;
  std::vector<std::vector<int>> frame_vertices_;
  size_t num_failed_pairs_ = 0;
};

}  // namespace colmap
