// Disjoint sets of the integers 0..n-1 (union-find with path halving), for
// the connected components of view graphs, community graphs and spanning
// trees.

#pragma once

#include <utility>
#include <vector>

namespace colmap {

class UnionFind {
 public:
  explicit UnionFind(int num_elements);

  // The representative of the element's set.
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
