#include "colmap_ext/util/union_find.h"

#include "colmap/util/logging.h"

#include <algorithm>
#include <numeric>

namespace colmap {

DisjointSets::DisjointSets(const int num_elements) : parent_(num_elements) {
  THROW_CHECK_GE(num_elements, 0);
  std::iota(parent_.begin(), parent_.end(), 0);
}

int DisjointSets::Find(int element) {
  while (parent_[element] != element) {
    parent_[element] = parent_[parent_[element]];
    element = parent_[element];
  }
  return element;
}

bool DisjointSets::Union(const int element1, const int element2) {
  const int root1 = Find(element1);
  const int root2 = Find(element2);
  parent_[std::max(root1, root2)] = std::min(root1, root2);
  return root1 != root2;
}

std::vector<int> ConnectedComponentLabels(
    const int num_nodes, const std::vector<std::pair<int, int>>& edges) {
  DisjointSets sets(num_nodes);
  for (const auto& edge : edges) {
    sets.Union(edge.first, edge.second);
  }
  std::vector<int> labels(num_nodes);
  for (int node = 0; node < num_nodes; ++node) {
    labels[node] = sets.Find(node);
  }
  return labels;
}

}  // namespace colmap
