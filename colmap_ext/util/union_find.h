// Disjoint sets of the integers 0..n-1, for the connected components of view
// graphs, community graphs and spanning trees.
//
// COLMAP's UnionFind<T> (colmap/math/union_find.h) keys a hash map by element
// and compresses paths recursively, so that a long chain (the view graph of a
// video sequence, matched frame to frame) recurses once per element. These
// sets live in one vector and halve paths in a loop, and the smallest element
// represents its set, so that labels do not depend on the order of the edges.

#pragma once

#include <utility>
#include <vector>

namespace colmap {

class DisjointSets {
 public:
  explicit DisjointSets(int num_elements);

  // The representative of the element's set: its smallest element.
  int Find(int element);

  // Joins the sets of the two elements; false if they were one set already.
  bool Union(int element1, int element2);

 private:
  std::vector<int> parent_;
};

// Per node 0..num_nodes-1, the smallest node of its connected component.
std::vector<int> ConnectedComponentLabels(
    int num_nodes, const std::vector<std::pair<int, int>>& edges);

}  // namespace colmap
